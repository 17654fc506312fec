"""VRML97 codec: read and write complete VRML97 scene graphs.  Knows nothing of faces.

>>> from mpeg4fba import vrml
>>> scene = vrml.loads("#VRML V2.0 utf8\\nDEF T Transform { children Shape { geometry Box {} } }")
>>> scene.find("T")["children"][0]["geometry"].type
'Box'
>>> vrml.loads(vrml.dumps(scene)) == scene
True
"""
from .catalogue import NODE_TYPES, VRML97_NODES, FieldDecl, NodeType
from .errors import VRMLError
from .fields import FIELD_TYPES, FieldType, Image
from .inflate import inflate_limits
from .reader import VRMLWarning, load, loads
from .scene import ExternProto, Node, Proto, RawValue, Route, Scene
from .writer import dump, dumps

__all__ = ["load", "loads", "dump", "dumps", "Scene", "Node", "Proto", "ExternProto", "Route",
           "RawValue", "FieldDecl", "NodeType", "NODE_TYPES", "VRML97_NODES", "FIELD_TYPES",
           "FieldType", "Image", "VRMLError", "VRMLWarning", "inflate_limits"]
