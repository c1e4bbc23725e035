"""Test order: the long integration tests first, then the other integration tests, then
the unit tests. With pytest-xdist workers side by side (`make test`, TEST_JOBS), a run
that starts its longest tests first does not end with one worker alone on them."""


def pytest_collection_modifyitems(session, config, items):
    def tier(item):
        if item.get_closest_marker("long"):
            return 0
        return 1 if item.get_closest_marker("integration") else 2
    items.sort(key=tier)   # stable: each tier keeps its collection order
