"""Lets the tests import their helper module (synthetic_world) under pytest's
--import-mode=importlib, which does not put the test folder on sys.path."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
