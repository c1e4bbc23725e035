"""dynamic_reconfigure servers that refuse out-of-range values instead of clamping them.

dynamic_reconfigure's own Python server silently clamps a value outside the .cfg's range
to the nearest bound; here a refused value keeps the parameter as it was and the node
logs which parameter, the value asked for and the valid range (the reply to
``dynparam set`` / rqt_reconfigure shows the value kept). Shared by move_base
(its planners, the inflation layers) and amcl.

At start the server takes from the parameter server only the values of the .cfg's type
(a YAML list for a str_t parameter, such as base_local_planner's y_vels, is left to the
node, whose callback reports the value in use); dynamic_reconfigure's own server would
fail comparing it with the range.

    server = StrictServer(DWAPlannerConfig, on_reconfigure, namespace="~DWAPlannerROS")
"""
import rospy
from dynamic_reconfigure.encoding import extract_params
from dynamic_reconfigure.server import Server

# .cfg type -> the Python types a value of it may have on the parameter server
_CFG_TYPES = {"double": (int, float), "int": (int,), "bool": (bool,), "str": (str,)}


def of_cfg_type(cfg_type, value):
    """Whether value may stand for a parameter of .cfg type cfg_type ('double', 'int', ...)."""
    kinds = _CFG_TYPES.get(cfg_type)
    if kinds is None:
        return True
    return isinstance(value, kinds) and not (bool not in kinds and isinstance(value, bool))


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

    def _copy_from_parameter_server(self):
        for param in extract_params(self.type.config_description):
            try:
                value = rospy.get_param(self.ns + param["name"])
            except KeyError:
                continue
            if of_cfg_type(param["type"], value):
                self.config[param["name"]] = value

    def update_configuration(self, changes):
        bad = out_of_range(self.type, changes)
        for name, (value, lo, hi) in bad.items():
            rospy.logwarn(f"{rospy.get_name()}: reconfigure refused {name} = {value}: valid range "
                          f"[{lo}, {hi}]; keeping {self.config.get(name)}")
        return super().update_configuration({k: v for k, v in changes.items() if k not in bad})
