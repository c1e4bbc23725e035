"""Moved to summit_nav_common.testing.roslaunch_session (issue 43); this name stays only
until the scripts still importing it from tools/ are swept, then goes."""
from summit_nav_common.testing.roslaunch_session import *  # noqa: F401,F403
from summit_nav_common.testing.roslaunch_session import RESULT_PREFIX, CHILD_STOP_GRACE  # noqa: F401
