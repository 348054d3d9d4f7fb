"""FreeCAD document side of Idealize, without any GUI: the core's results as FreeCAD meshes,
shapes and document objects (the feature layer). The GUI (idealize.gui) adds commands, view
providers and task panels; the core API (idealize) imports nothing of FreeCAD.

    mesh          Mesh::Feature <-> idealize.Mesh, colours, segmentation and layer meshes
    solid         the fitted solid and its primitives as Part objects
    layer_object  the feature layer document object
"""
