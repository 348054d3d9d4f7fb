"""Pre-selection and selection of a feature layer shown feature by feature.

A click on a feature layer selects the facet under the pointer ("FacetN", see
view_layer.ViewProviderFeatureLayer.getElementPicked): its feature is what the editing commands
work on. FreeCAD's mesh view highlights the whole object when any part of it is pre-selected or
selected, which would say nothing about which feature a click takes. Here the mesh's own highlight
is turned off, and the faces of the feature under the pointer (pre-selection colour) and of the
selected features (selection colour; every feature when the whole object is selected, as from the
tree) are drawn over the layer instead, from the user's colour preferences.

The overlay shares the layer's own coordinate node (no copy of the mesh; it follows the mesh when it
changes) and draws the features' triangles with a polygon offset towards the viewer. It is never
picked, so picks still reach the layer. One Selection observer serves every layer.
"""
import FreeCAD
import FreeCADGui
import numpy as np

from ..freecad import layer_object
from ..freecad.mesh import mesh_from_freecad

# FreeCAD's defaults for the pre-selection and selection colours (Preferences → Display → Colors),
# used when the user has not set them: the packed RGBA of its View parameters.
_DEFAULT_COLORS = {"HighlightColor": 0xE1E114FF, "SelectionColor": 0x1CAD1CFF}


def _user_color(name):
    packed = FreeCAD.ParamGet("User parameter:BaseApp/Preferences/View").GetUnsigned(name, _DEFAULT_COLORS[name])
    return tuple(((packed >> shift) & 255) / 255.0 for shift in (24, 16, 8))


def _find(root, type_name):
    """The first node of Coin type `type_name` under `root`, or None."""
    from pivy import coin
    kind = coin.SoType.fromName(type_name)
    if kind == coin.SoType.badType():
        return None
    search = coin.SoSearchAction()
    search.setType(kind)
    search.setInterest(coin.SoSearchAction.FIRST)
    search.setSearchingAll(True)
    search.apply(root)
    path = search.getPath()
    return path.getTail() if path is not None else None


class FeatureHighlight:
    """The overlay of one layer's view provider: `show("pre", features)` and `show("sel", features)`
    draw those features' faces in the pre-selection and selection colours."""

    def __init__(self, vobj):
        self.vobj = vobj
        self.node = None       # the overlay (a switch), built on first use
        self.faces = {}        # "pre" / "sel" -> their SoIndexedFaceSet
        self.shown = {"pre": (), "sel": ()}
        self._triangles = None  # the layer's triangles and labels, until the layer changes
        self._labels = None

    def _build(self):
        """The overlay under the layer's root (after its transform), sharing its coordinates; False
        when the mesh view draws without a coordinate node (then FreeCAD's own highlight stays)."""
        from pivy import coin
        root = self.vobj.RootNode
        selection = _find(root, "SoFCSelection")
        coordinates = _find(selection, "SoCoordinate3") if selection is not None else None
        if coordinates is None:
            return False
        # The mesh's whole-object highlight and selection colour off: the overlay shows them.
        selection.getField("highlightMode").set("OFF")
        selection.getField("selectionMode").set("SEL_OFF")
        selection.getField("useNewSelection").set("FALSE")
        self.node = coin.SoSwitch()
        group = coin.SoSeparator()
        style = coin.SoPickStyle()
        style.style = coin.SoPickStyle.UNPICKABLE
        offset = coin.SoPolygonOffset()  # in front of the layer's own faces, which lie in the same place
        offset.factor = -1.0
        offset.units = -1.0
        # The mesh view's state reaches here (its display modes are groups, not separators): one
        # colour for all faces, not its colour per facet.
        binding = coin.SoMaterialBinding()
        binding.value = coin.SoMaterialBinding.OVERALL
        hints = coin.SoShapeHints()
        hints.vertexOrdering = coin.SoShapeHints.COUNTERCLOCKWISE
        for child in (style, offset, binding, hints, coordinates):
            group.addChild(child)
        for kind, color in (("sel", _user_color("SelectionColor")), ("pre", _user_color("HighlightColor"))):
            part = coin.SoSeparator()
            material = coin.SoMaterial()
            material.diffuseColor.setValue(*color)
            material.emissiveColor.setValue(*[0.4 * c for c in color])  # lit from any side, as FreeCAD's highlight
            self.faces[kind] = coin.SoIndexedFaceSet()
            part.addChild(material)
            part.addChild(self.faces[kind])
            group.addChild(part)
        self.node.addChild(group)
        self.node.whichChild = 0 if self.vobj.Visibility else -1
        root.addChild(self.node)
        return True

    def _layer_arrays(self):
        """(triangles #F x 3, labels #F) of the layer's mesh, cached until the mesh changes."""
        if self._triangles is None:
            obj = self.vobj.Object
            self._triangles = mesh_from_freecad(obj.Mesh).faces
            self._labels = np.asarray(obj.Labels, dtype=np.int32)
        return self._triangles, self._labels

    def layer_changed(self):
        """The layer's mesh or labels changed: the features shown are drawn from the new ones."""
        self._triangles = self._labels = None
        if self.node is not None:
            for kind, features in list(self.shown.items()):
                self.shown[kind] = None
                self.show(kind, features)

    def feature_of(self, facet):
        """The feature of facet `facet` of the layer, or None."""
        _, labels = self._layer_arrays()
        if not 0 <= facet < len(labels) or labels[facet] < 0:
            return None
        return int(labels[facet])

    def features_of(self, elements):
        """The features that the selection's sub-elements of the layer name: those of its facets, or
        every feature for the whole object (no sub-element, as the tree selects it)."""
        _, labels = self._layer_arrays()
        if not elements or any(not element for element in elements):
            return [int(f) for f in np.unique(labels) if f >= 0]
        features = (self.feature_of(facet) for facet in map(_facet, elements) if facet is not None)
        return [f for f in features if f is not None]

    def show(self, kind, features):
        features = tuple(sorted(set(features)))
        if features == self.shown[kind]:
            return
        if self.node is None and not self._build():
            return
        self.shown[kind] = features
        triangles, labels = self._layer_arrays()
        mine = triangles[np.isin(labels, features)] if features else triangles[:0]
        index = np.hstack([mine, -np.ones((len(mine), 1), dtype=np.int32)]).astype(np.int32).ravel()
        faces = self.faces[kind]
        faces.coordIndex.setNum(len(index))
        if len(index):
            faces.coordIndex.setValues(0, len(index), index)

    def set_visible(self, visible):
        if self.node is not None:
            self.node.whichChild = 0 if visible else -1


def _highlight(document, name):
    """The FeatureHighlight of layer `name` of document `document`, or None."""
    doc = FreeCAD.listDocuments().get(document)
    obj = doc.getObject(name) if doc is not None else None
    if obj is None or not layer_object.is_feature_layer(obj) or obj.ViewObject is None:
        return None
    return getattr(obj.ViewObject.Proxy, "highlight", None)


def _facet(element):
    if element and element.startswith("Facet") and element[len("Facet"):].isdigit():
        return int(element[len("Facet"):])
    return None


class _Observer:
    """Gui.Selection observer: the feature of the pre-selected facet, and the features of the
    selected facets, of every feature layer."""

    def __init__(self):
        self.pre = None  # (document, name) of the layer with a pre-selection shown

    def setPreselection(self, document, name, element):
        self.removePreselection("", "", "")
        highlight = _highlight(document, name)
        if highlight is None:
            return
        highlight.show("pre", highlight.features_of([element]))
        self.pre = (document, name)

    def removePreselection(self, document, name, element):
        if self.pre is not None:
            highlight = _highlight(*self.pre)
            if highlight is not None:
                highlight.show("pre", ())
            self.pre = None

    def _refresh(self, document):
        """Show the selected features of every layer of `document` (all documents when empty)."""
        chosen = {}  # (document, object) -> its selected sub-elements ("" for the whole object)
        for entry in FreeCADGui.Selection.getSelectionEx(document or "*"):
            chosen.setdefault((entry.DocumentName, entry.ObjectName), []).extend(entry.SubElementNames or [""])
        for doc in FreeCAD.listDocuments().values():
            if document and doc.Name != document:
                continue
            for obj in doc.Objects:
                highlight = _highlight(doc.Name, obj.Name)
                if highlight is None:
                    continue
                elements = chosen.get((doc.Name, obj.Name))
                highlight.show("sel", highlight.features_of(elements) if elements else ())

    def addSelection(self, document, name, element, point):
        self._refresh(document)

    def removeSelection(self, document, name, element):
        self._refresh(document)

    def setSelection(self, document):
        self._refresh(document)

    def clearSelection(self, document):
        self._refresh(document)


_observer = None


def install():
    """Add the one Selection observer (once per session)."""
    global _observer
    if _observer is None:
        _observer = _Observer()
        FreeCADGui.Selection.addObserver(_observer)
