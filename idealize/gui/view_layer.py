"""View provider of the feature layer: the idealized mesh coloured by feature type (the thesis's
colours), by feature, or by deviation with a legend; double-click opens the task panel."""
import json

import FreeCADGui

from .. import layer_object
from ..freecad_mesh import FACE_COLORS, deviation_colors
from . import icon


class ViewProviderFeatureLayer:
    def __init__(self, vobj):
        vobj.Proxy = self
        vobj.addProperty("App::PropertyEnumeration", "ColorBy", "Idealize",
                         "Colour the facets by feature type (plane light green, cylinder yellow, cone light blue, "
                         "sphere dark green, torus dark red, freeform grey), by feature, or by deviation")
        vobj.ColorBy = layer_object.COLOR_MODES
        vobj.Coloring = True

    def attach(self, vobj):
        self.Object = vobj.Object
        self.legend = None
        self.panel = None

    def _legend(self, vobj):
        if self.legend is None:
            from .legend import ColorLegend
            self.legend = ColorLegend()
            vobj.RootNode.addChild(self.legend.node)
        return self.legend

    def update_legend(self, vobj):
        """Show the deviation legend when the layer is shown by deviation, hide it otherwise."""
        deviation = vobj.Visibility and getattr(vobj, "ColorBy", "Type") == "Deviation"
        if deviation:
            obj = vobj.Object
            top = layer_object.deviation_scale(obj.VertexDeviation, json.loads(obj.FeatureTable)["distance_tolerance"])
            self._legend(vobj).update("Deviation (mm)", top, lambda t: tuple(deviation_colors([t], 1.0)[0]))
        if self.legend is not None:
            self.legend.show(deviation)

    def onChanged(self, vobj, prop):
        if prop == "ColorBy" and layer_object.is_feature_layer(vobj.Object) and vobj.Object.FeatureTable:
            layer_object.set_colors(vobj.Object, vobj.ColorBy)
            self.update_legend(vobj)
        elif prop == "Visibility":
            self.update_legend(vobj)

    def updateData(self, obj, prop):
        vobj = obj.ViewObject
        if prop == FACE_COLORS and vobj.Coloring:
            # The mesh view reads the colours when Coloring is switched on, not when they change.
            vobj.Coloring = False
            vobj.Coloring = True
        elif prop == "VertexDeviation" and getattr(vobj, "ColorBy", None) == "Deviation":
            self.update_legend(vobj)

    def getIcon(self):
        return icon("Idealize_SegmentIdealize")

    def doubleClicked(self, vobj):
        FreeCADGui.ActiveDocument.setEdit(vobj.Object.Name)
        return True

    def setEdit(self, vobj, mode=0):
        if mode != 0:
            return None
        from .task_layer import FeatureLayerPanel
        self.panel = FeatureLayerPanel(vobj.Object)  # kept for the console and tests
        FreeCADGui.Control.showDialog(self.panel)
        return True

    def unsetEdit(self, vobj, mode=0):
        if mode != 0:
            return None
        FreeCADGui.Control.closeDialog()
        self.panel = None
        return True

    def dumps(self):
        return None

    def loads(self, state):
        return None
