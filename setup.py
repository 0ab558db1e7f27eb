# setuptools still needs setup.py for cffi_modules (python-cffi/cffi#55); everything else is in pyproject.toml.
from setuptools import setup

setup(cffi_modules=["runtime_py/uavbus/_build_ffi.py:ffibuilder"])
