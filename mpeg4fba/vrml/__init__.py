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

import importlib
from typing import Any

from .errors import VRMLError
from .inflate import inflate_limits

_LAZY = {
    **{name: "catalogue" for name in ("NODE_TYPES", "VRML97_NODES", "FieldDecl", "NodeType")},
    **{name: "fields" for name in ("FIELD_TYPES", "FieldType", "Image")},
    **{name: "reader" for name in ("VRMLWarning", "load", "loads")},
    **{name: "scene" for name in ("ExternProto", "Node", "Proto", "RawValue", "Route", "Scene")},
    **{name: "writer" for name in ("dump", "dumps")},
}

__all__ = ["load", "loads", "dump", "dumps", "Scene", "Node", "Proto", "ExternProto", "Route",
           "RawValue", "FieldDecl", "NodeType", "NODE_TYPES", "VRML97_NODES", "FIELD_TYPES",
           "FieldType", "Image", "VRMLError", "VRMLWarning", "inflate_limits"]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'mpeg4fba.vrml' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list:
    return sorted(set(globals()) | set(__all__))
