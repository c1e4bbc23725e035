"""Moved to summit_nav_common.testing.profile_node (issue 43); this name stays only until
the scripts still importing it from tools/ are swept, then goes."""
from summit_nav_common.testing.profile_node import *  # noqa: F401,F403
