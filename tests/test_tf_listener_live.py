"""summit_nav_common.ros.tf_listener and tf_broadcast on a live master.

A node that broadcasts map -> odom through PeriodicTransform and listens through
TransformListener must: not be connected to its own /tf publisher, still have its own
transform in its buffer, get other nodes' transforms (and on_update for each of their
messages only), and reach every other node's listener as tf2_ros's broadcaster would.
"""
import os
import subprocess
import sys

import pytest

from summit_nav_common.testing.roslaunch_session import Roscore, stop_process_tree

TIMEOUT = 60.0  # [s] wall, generous under load

NODE = r'''
import json, sys, time
import rospy, tf2_ros
from summit_nav_common.ros.tf_broadcast import PeriodicTransform
from summit_nav_common.ros.tf_listener import TransformListener

rospy.init_node("broadcaster")
buf = tf2_ros.Buffer()
updates = []
listener = TransformListener(buf, on_update=lambda: updates.append(time.monotonic()))
pt = PeriodicTransform("map", "odom", 0.05, 0.0, lambda: (1.0, 2.0, 0.5), listener)
pt.start()
deadline = time.monotonic() + 30.0
while time.monotonic() < deadline and not buf.can_transform("map", "base_link", rospy.Time(0)):
    time.sleep(0.1)
time.sleep(2.0)
sub = listener._subs[0].impl
t = buf.lookup_transform("map", "base_link", rospy.Time(0))
print(json.dumps(dict(
    own_uri=rospy.core.get_node_uri(),
    connected=[c.endpoint_id for c in sub.connections],
    x=t.transform.translation.x, y=t.transform.translation.y,
    update_rate=(len(updates) - 1) / (updates[-1] - updates[0]), sent=pt.sent)), flush=True)
'''

OTHER = r'''
import json, time
import rospy, tf2_ros
from geometry_msgs.msg import TransformStamped
rospy.init_node("odometry")
pub = tf2_ros.TransformBroadcaster()
buf = tf2_ros.Buffer()
tf2_ros.TransformListener(buf)
t = TransformStamped()
t.header.frame_id, t.child_frame_id = "odom", "base_link"
t.transform.translation.x = 0.5
t.transform.rotation.w = 1.0
sent = 0
end = time.monotonic() + 40.0
seen = None
while time.monotonic() < end and not rospy.is_shutdown():
    t.header.stamp = rospy.Time.now()
    pub.sendTransform(t)
    sent += 1
    if seen is None and buf.can_transform("map", "odom", rospy.Time(0)):
        m = buf.lookup_transform("map", "odom", rospy.Time(0))
        seen = [m.transform.translation.x, m.transform.translation.y]
        print(json.dumps(dict(seen=seen)), flush=True)
    time.sleep(0.05)
'''


@pytest.mark.integration
def test_listener_skips_its_own_broadcasts_and_keeps_the_rest(tmp_path):
    import json
    (tmp_path / "node.py").write_text(NODE)
    (tmp_path / "other.py").write_text(OTHER)
    with Roscore(env=dict(os.environ, ROS_LOG_DIR=str(tmp_path / "log"), ROS_HOME=str(tmp_path)),
                 timeout=TIMEOUT, caller="/test_tf_listener") as core:
        other = subprocess.Popen([sys.executable, str(tmp_path / "other.py")], stdout=subprocess.PIPE,
                                 stderr=subprocess.STDOUT, text=True, env=core.env, start_new_session=True)
        try:
            node = subprocess.run([sys.executable, str(tmp_path / "node.py")], capture_output=True, text=True,
                                  env=core.env, timeout=TIMEOUT)
            seen_line = other.stdout.readline()
        finally:
            stop_process_tree(other, grace=5.0)
    assert node.returncode == 0, node.stdout[-2000:] + node.stderr[-3000:]
    r = json.loads(node.stdout.strip().splitlines()[-1])
    assert r["connected"], "the /tf subscription is connected to nobody: the odometry's transforms cannot come"
    assert r["own_uri"] not in r["connected"], r
    # map -> odom (own, straight into the buffer) then odom -> base_link (the other node's)
    assert (r["x"], r["y"]) == pytest.approx((1.0 + 0.5 * 0.8775825618903728, 2.0 + 0.5 * 0.479425538604203))
    assert r["sent"] > 10
    # on_update for the other's messages only: at most its 20 Hz, not 40 Hz with our own
    assert 5.0 < r["update_rate"] < 25.0, r
    assert json.loads(seen_line)["seen"] == pytest.approx([1.0, 2.0]), "another node did not get map -> odom"
