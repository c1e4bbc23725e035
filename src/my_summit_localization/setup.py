# Installs the my_summit_localization Python package (catkin_python_setup(); do not run directly).
from setuptools import setup

from catkin_pkg.python_setup import generate_distutils_setup

d = generate_distutils_setup(packages=['my_summit_localization'], package_dir={'': 'src'})
setup(**d)
