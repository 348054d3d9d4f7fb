"""Where documents saved by Idealize 0.1 look for the feature layer's proxy (FreeCAD stores its
module and class name): the document object now lives in idealize.freecad.layer_object."""
from .freecad.layer_object import FeatureLayerObject  # noqa: F401
