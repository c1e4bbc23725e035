"""summit_nav_common.seq_gaps: scans lost on the way, counted from header.seq."""
from summit_nav_common.seq_gaps import SeqGaps


def test_consecutive_numbers_skip_nothing():
    g = SeqGaps()
    assert [g.observe(s) for s in range(1, 6)] == [0, 0, 0, 0, 0]
    assert (g.received, g.skipped) == (5, 0)


def test_a_gap_counts_the_missing_numbers():
    g = SeqGaps()
    gaps = [g.observe(s) for s in (7, 8, 11, 12, 20)]
    assert gaps == [0, 0, 2, 0, 7]            # 9, 10 and 13..19 never arrived
    assert (g.received, g.skipped) == (5, 9)


def test_a_restart_is_not_a_gap():
    """A publisher that restarts (or a bag that loops) numbers from 1 again."""
    g = SeqGaps()
    for s in (100, 101, 1, 2, 4):
        g.observe(s)
    assert (g.received, g.skipped) == (5, 1)


def test_unnumbered_messages_are_never_counted():
    g = SeqGaps()
    for _ in range(4):
        g.observe(0)
    assert (g.received, g.skipped) == (4, 0)


def test_a_message_dropped_after_it_arrived_is_skipped_too():
    """slam_gmapping's filter queue and the tf message filters drop the oldest scan when
    full: the scan was received (no seq gap) but never used."""
    g = SeqGaps()
    for s in (1, 2, 3):
        g.observe(s)
    g.drop()
    g.observe(5)
    assert (g.received, g.skipped, g.dropped) == (4, 2, 1)
