"""summit_nav_common.testing.profile_node.stage_shares: a profile split into stages, inner stages subtracted."""
import cProfile
import os
import time

from summit_nav_common.testing import profile_node


def busy(seconds):
    end = time.process_time() + seconds
    while time.process_time() < end:
        pass


def inner():
    busy(0.2)


def outer():
    inner()
    busy(0.2)


def elsewhere():
    busy(0.1)


def test_stage_shares_subtract_the_stages_inside(tmp_path):
    prof = cProfile.Profile(time.process_time)
    prof.enable()
    outer()
    elsewhere()
    prof.disable()
    path = str(tmp_path / "p.pstats")
    prof.dump_stats(path)
    here = os.path.basename(__file__)
    stages = [("inner", [(here, "inner")]), ("outer, own", [(here, "outer")])]
    shares = profile_node.stage_shares(path, stages, {1: [0]})
    # 0.2 s inner, 0.2 s outer's own, 0.1 s in no stage, of 0.5 s
    assert abs(shares["inner"] - 0.4) < 0.05
    assert abs(shares["outer, own"] - 0.4) < 0.05
    assert abs(shares["other"] - 0.2) < 0.05
    # without saying outer contains inner, inner's time is counted twice
    assert profile_node.stage_shares(path, stages, {})["outer, own"] > 0.75


class _PublisherImpl:
    def publish(self):
        busy(0.2)


class Publisher:
    def publish(self):
        busy(0.1)
        _PublisherImpl().publish()


def test_a_stage_of_functions_calling_each_other_counts_their_time_once(tmp_path):
    """The simulator's first profile gave "publishing" 53% of its CPU: rospy's
    Publisher.publish and the _PublisherImpl.publish it calls share the stage's key
    (rospy/topics.py, publish), and their cumulative times were added."""
    prof = cProfile.Profile(time.process_time)
    prof.enable()
    Publisher().publish()
    elsewhere()
    prof.disable()
    path = str(tmp_path / "p.pstats")
    prof.dump_stats(path)
    here = os.path.basename(__file__)
    shares = profile_node.stage_shares(path, [("publishing", [(here, "publish")])], {})
    # 0.3 s in Publisher.publish (0.2 s of it in _PublisherImpl.publish), 0.1 s elsewhere, of 0.4 s
    assert abs(shares["publishing"] - 0.75) < 0.05
    assert abs(shares["other"] - 0.25) < 0.05
