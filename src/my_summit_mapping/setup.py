# Installs the my_summit_mapping Python package (catkin_python_setup(); do not run directly).
from setuptools import setup

from catkin_pkg.python_setup import generate_distutils_setup

d = generate_distutils_setup(packages=['my_summit_mapping', 'my_summit_mapping.karto'], package_dir={'': 'src'})
setup(**d)
