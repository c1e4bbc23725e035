"""dynamic_reconfigure servers that refuse out-of-range values instead of clamping them.

dynamic_reconfigure's own Python server silently clamps a value outside the .cfg's range
to the nearest bound; here a refused value keeps the parameter as it was and the node
logs which parameter, the value asked for and the valid range (the reply to
``dynparam set`` / rqt_reconfigure shows the value kept). Shared by move_base
(DWAPlannerROS, the inflation layers) and amcl.

    server = StrictServer(DWAPlannerConfig, on_reconfigure, namespace="~DWAPlannerROS")
"""
import rospy
from dynamic_reconfigure.server import Server


def out_of_range(config_type, changes):
    """{name: (value, min, max)} of the changes outside their .cfg range."""
    bad = {}
    for name, value in changes.items():
        if name not in config_type.max or isinstance(value, (str, bool)):
            continue
        lo, hi = config_type.min[name], config_type.max[name]
        if (hi != "" and value > hi) or (lo != "" and value < lo):
            bad[name] = (value, lo, hi)
    return bad


class StrictServer(Server):
    """dynamic_reconfigure.server.Server, but an out-of-range change is refused."""

    def update_configuration(self, changes):
        bad = out_of_range(self.type, changes)
        for name, (value, lo, hi) in bad.items():
            rospy.logwarn(f"{rospy.get_name()}: reconfigure refused {name} = {value}: valid range "
                          f"[{lo}, {hi}]; keeping {self.config.get(name)}")
        return super().update_configuration({k: v for k, v in changes.items() if k not in bad})
