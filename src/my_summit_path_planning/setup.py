# ! DO NOT MANUALLY INVOKE THIS setup.py, USE CATKIN INSTEAD
from setuptools import setup

from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(packages=['my_summit_path_planning', 'my_summit_path_planning.ros'], package_dir={'': 'src'}))
