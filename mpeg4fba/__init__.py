"""mpeg4fba: MPEG-4 Face and Body Animation toolkit.

>>> import mpeg4fba as fba
>>> fba.vrml.loads("#VRML V2.0 utf8\\nGroup {}").nodes[0].type
'Group'
"""
from . import vrml

__version__ = "0.1.0"
__all__ = ["vrml", "__version__"]
