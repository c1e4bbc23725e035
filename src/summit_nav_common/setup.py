from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(packages=["summit_nav_common", "summit_nav_common.ros",
                                           "summit_nav_common.testing"],
                                 package_dir={"": "src"}))
