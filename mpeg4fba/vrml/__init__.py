"""VRML97 codec: read and write complete VRML97 scene graphs.  Knows nothing of faces.

>>> from mpeg4fba import vrml
>>> scene = vrml.loads("#VRML V2.0 utf8\\nDEF T Transform { children Shape { geometry Box {} } }")
>>> scene.find("T")["children"][0]["geometry"].type
'Box'
>>> vrml.loads(vrml.dumps(scene)) == scene
True

The names are imported on first use (PEP 562): a program that only needs
:class:`VRMLError` or :func:`inflate_limits` (the command line's ``--help``) does not
load numpy, lark and the node catalogue.
"""
from __future__ import annotations

from .._lazy import lazy_names
from .errors import VRMLError, VRMLWarning
from .inflate import inflate_limits

_LAZY = {name: (f"{__name__}.{module}", name) for module, names in (
    ("catalogue", ("NODE_TYPES", "VRML97_NODES", "FieldDecl", "NodeType")),
    ("fields", ("FIELD_TYPES", "FieldType", "Image")),
    ("reader", ("load", "loads")),
    ("scene", ("ExternProto", "Node", "Proto", "RawValue", "Route", "Scene")),
    ("writer", ("dump", "dumps"))) for name in names}

__all__ = ["load", "loads", "dump", "dumps", "Scene", "Node", "Proto", "ExternProto", "Route",
           "RawValue", "FieldDecl", "NodeType", "NODE_TYPES", "VRML97_NODES", "FIELD_TYPES",
           "FieldType", "Image", "VRMLError", "VRMLWarning", "inflate_limits"]


__getattr__, __dir__ = lazy_names(globals(), _LAZY)
