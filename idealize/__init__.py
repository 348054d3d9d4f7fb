"""Idealize: turn triangle meshes of prismatic mechanical parts into features and CAD.

Console use (plain Python or FreeCAD)::

    import idealize
    mesh = idealize.load_mesh("part.stl")
    seg = idealize.segment(mesh)
    seg.labels        # one patch id per input triangle, -1 on transitions
    seg.patches       # one summary dict per patch
    layer = idealize.idealize(mesh)
    layer.features    # type, params, rms per feature
    layer.relations   # parallel, coaxial, tangent, ...
    solid = idealize.make_solid(layer)
    solid.solid       # True: a valid closed solid
    solid.write_step("part.step")

Long calls take ``progress=idealize.Progress()`` to be watched and cancelled from another thread
(see idealize.progress).
"""
from .brep import Solid, make_solid
from .curvature import vertex_curvature
from .features import FeatureLayer, idealize
from .mesh import Mesh, MeshError, load_mesh
from .progress import Cancelled, Progress
from .reidealize import reidealize
from .segmentation import Segmentation, segment

__all__ = ["Cancelled", "FeatureLayer", "feature_layer", "Mesh", "MeshError", "idealize", "load_mesh",
           "make_feature_layer", "make_solid", "Progress", "reidealize", "Segmentation", "segment", "Solid", "vertex_curvature"]
__version__ = "0.1.0"


def __getattr__(name):
    """feature_layer and make_feature_layer, the feature layer document object's functions, come
    from idealize.freecad when first asked for: importing idealize imports nothing of FreeCAD."""
    if name in ("feature_layer", "make_feature_layer"):
        from .freecad import layer_object
        return getattr(layer_object, name)
    raise AttributeError("module 'idealize' has no attribute %r" % name)
