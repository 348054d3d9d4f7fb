"""Colour legend for the 3D view: a colour bar with a title and tick labels, drawn in screen space.

The legend is a Coin sub-graph, so it is part of the scene wherever the scene is rendered,
including offscreen by View.saveImage(). Typical use in a view-provider proxy::

    def attach(self, vobj):
        self.legend = ColorLegend()
        vobj.RootNode.addChild(self.legend.node)

    # when the deviation colouring is shown:
    self.legend.update("Deviation (mm)", top, color_at)
    self.legend.show(True)

Limits of living under the object's RootNode: nodes appended there are not under the display-mode
switch, so they stay drawn when the object is hidden (the proxy should call show(False) when
Visibility goes off); and Coin culls the whole RootNode, legend included, while the object's
bounding box is entirely outside the view.
"""
from pivy import coin

BANDS = 32                    # rows of the bar; colours are interpolated between rows
BAR_LEFT, BAR_RIGHT = 0.86, 0.90   # normalized viewport coordinates, -1..1 on both axes
BAR_BOTTOM, BAR_TOP = -0.34, 0.34  # a third of the view height
TEXT_COLOR = (0.05, 0.05, 0.05)
PLATE_COLOR = (0.95, 0.95, 0.95)
# Entries below the bar (a colour that is not on the scale, e.g. freeform grey): one swatch as wide
# as the bar per entry, ENTRY_HEIGHT tall, the first ENTRY_GAP below the bar (room for its "0").
ENTRY_GAP, ENTRY_HEIGHT, ENTRY_SPACING = 0.10, 0.06, 0.09
MAX_ENTRIES = 1  # the plate below is tall enough for this many (the layer needs one: freeform)
# left, right, bottom, top; wide enough for a ~15 character title in views from ~600 px wide, and
# tall enough for MAX_ENTRIES entries under the bar (plus a 0.02 margin)
PLATE = (0.56, 0.97, BAR_BOTTOM - ENTRY_GAP - MAX_ENTRIES * ENTRY_SPACING - 0.02, 0.50)
FONT = ("Sans", 13)  # Coin asks fontconfig; an unknown name falls back to Coin's built-in font


def _bbox_free(child):
    """Group that shows `child` to rendering only.

    Cameras do not isolate geometry from SoGetBoundingBoxAction, so without this the legend's
    -1..1 coordinates would enter the scene's bounding box (ViewFit, fit selection, the object's
    bounding box). FreeCAD's SoSkipBoundingGroup does not help: ViewFit sets every one of them
    back to INCLUDE_BBOX afterwards. An SoSwitch with SO_SWITCH_INHERIT takes its child index from the traversal
    state, which the callback before it sets per action: 0 for GL rendering, -1 (none) otherwise.
    """
    def choose(_, action):
        rendering = action.isOfType(coin.SoGLRenderAction.getClassTypeId())
        coin.SoSwitchElement.set(action.getState(), 0 if rendering else coin.SO_SWITCH_NONE)

    callback = coin.SoCallback()
    callback.setCallback(choose)
    switch = coin.SoSwitch()
    switch.whichChild = coin.SO_SWITCH_INHERIT
    switch.addChild(child)
    group = coin.SoSeparator()  # also keeps the switch element from leaking to later siblings
    group.addChild(callback)
    group.addChild(switch)
    return group


def _rectangle(left, right, bottom, top, rgb):
    sep = coin.SoSeparator()
    material = coin.SoBaseColor()
    material.rgb = rgb
    coords = coin.SoCoordinate3()
    coords.point.setValues(0, 4, [(left, bottom, 0), (right, bottom, 0), (right, top, 0), (left, top, 0)])
    face = coin.SoFaceSet()
    face.numVertices = 4
    for node in (material, coords, face):
        sep.addChild(node)
    return sep


class ColorLegend:
    """Screen-space colour bar (pivy/Coin) at the right edge of the view.

    `node` is an SoSwitch (hidden until show(True)); add it to a view provider's RootNode.
    """

    def __init__(self):
        self.node = coin.SoSwitch()
        self.node.whichChild = coin.SO_SWITCH_NONE

        # Annotation: drawn after the scene without depth test, so the model never covers it and
        # later siblings simply paint over earlier ones (plate, bar, lines, text).
        overlay = coin.SoAnnotation()
        pick = coin.SoPickStyle()
        pick.style = coin.SoPickStyle.UNPICKABLE
        light = coin.SoLightModel()
        light.model = coin.SoLightModel.BASE_COLOR  # exact colours, no shading
        camera = coin.SoOrthographicCamera()
        camera.viewportMapping = coin.SoCamera.LEAVE_ALONE  # -1..1 spans the viewport on both axes
        camera.position = (0, 0, 1)
        camera.height = 2
        camera.nearDistance = 0.5
        camera.farDistance = 1.5
        font = coin.SoFont()
        font.name, font.size = FONT
        # The reset comes first: a camera is placed by the current model matrix (here the
        # object's placement).
        for node in (coin.SoResetTransform(), pick, light, camera, font,
                     _rectangle(*PLATE, rgb=PLATE_COLOR)):
            overlay.addChild(node)

        bar = coin.SoSeparator()
        self._bar_coords = coin.SoCoordinate3()
        self._bar_colors = coin.SoMaterial()
        binding = coin.SoMaterialBinding()
        binding.value = coin.SoMaterialBinding.PER_VERTEX
        mesh = coin.SoQuadMesh()
        mesh.verticesPerRow = 2
        mesh.verticesPerColumn = BANDS + 1
        for node in (self._bar_coords, self._bar_colors, binding, mesh):
            bar.addChild(node)
        overlay.addChild(bar)
        # Rebuilt by update(): the swatches of the entries below the bar (before the outlines).
        self._entries = coin.SoSeparator()
        overlay.addChild(self._entries)

        ink = coin.SoBaseColor()
        ink.rgb = TEXT_COLOR
        overlay.addChild(ink)
        outline = coin.SoSeparator()
        self._line_coords = coin.SoCoordinate3()
        self._lines = coin.SoLineSet()
        outline.addChild(self._line_coords)
        outline.addChild(self._lines)
        overlay.addChild(outline)
        # Rebuilt by update(): one translated SoText2 per label.
        self._labels = coin.SoSeparator()
        overlay.addChild(self._labels)

        self.node.addChild(_bbox_free(overlay))
        self.entries = []  # labels of the entries below the bar (update())

    def update(self, title, top, color_at, ticks=5, unit_format="%.3g", extra=()):
        """Show values 0..top: color_at(t) -> (r, g, b) in 0..1 for t in [0, 1]; `ticks` labels
        evenly spaced, formatted with unit_format; `title` above the bar; `extra`: up to
        MAX_ENTRIES (label, (r, g, b)) entries below the bar for colours off the scale."""
        rows = [i / BANDS for i in range(BANDS + 1)]
        height = BAR_TOP - BAR_BOTTOM
        points, colors = [], []
        for t in rows:
            y = BAR_BOTTOM + t * height
            points += [(BAR_LEFT, y, 0), (BAR_RIGHT, y, 0)]
            colors += [tuple(float(c) for c in color_at(t))] * 2
        self._bar_coords.point.setValues(0, len(points), points)
        self._bar_coords.point.setNum(len(points))
        self._bar_colors.diffuseColor.setValues(0, len(colors), colors)
        self._bar_colors.diffuseColor.setNum(len(colors))

        ticks = max(ticks, 2)
        lines = [(BAR_LEFT, BAR_BOTTOM, 0), (BAR_RIGHT, BAR_BOTTOM, 0), (BAR_RIGHT, BAR_TOP, 0),
                 (BAR_LEFT, BAR_TOP, 0), (BAR_LEFT, BAR_BOTTOM, 0)]
        self._labels.removeAllChildren()
        for i in range(ticks):
            t = i / (ticks - 1)
            y = BAR_BOTTOM + t * height
            lines += [(BAR_LEFT - 0.012, y, 0), (BAR_LEFT, y, 0)]
            self._add_text(unit_format % (t * top), BAR_LEFT - 0.02, y - 0.012)
        self._add_text(title, BAR_RIGHT, BAR_TOP + 0.05)
        self._entries.removeAllChildren()
        self.entries = [label for label, _ in extra[:MAX_ENTRIES]]
        for i, (label, rgb) in enumerate(extra[:MAX_ENTRIES]):
            top_y = BAR_BOTTOM - ENTRY_GAP - i * ENTRY_SPACING
            self._entries.addChild(_rectangle(BAR_LEFT, BAR_RIGHT, top_y - ENTRY_HEIGHT, top_y,
                                              tuple(float(c) for c in rgb)))
            lines += [(BAR_LEFT, top_y - ENTRY_HEIGHT, 0), (BAR_RIGHT, top_y - ENTRY_HEIGHT, 0), (BAR_RIGHT, top_y, 0),
                      (BAR_LEFT, top_y, 0), (BAR_LEFT, top_y - ENTRY_HEIGHT, 0)]
            self._add_text(label, BAR_LEFT - 0.02, top_y - ENTRY_HEIGHT / 2 - 0.012)
        self._line_coords.point.setValues(0, len(lines), lines)
        self._line_coords.point.setNum(len(lines))
        counts = [5] + [2] * ticks + [5] * len(self.entries)
        self._lines.numVertices.setValues(0, len(counts), counts)
        self._lines.numVertices.setNum(len(counts))

    def _add_text(self, text, x, y):
        """Right-aligned label ending at (x, y): text grows to the left, away from the edge."""
        sep = coin.SoSeparator()
        move = coin.SoTranslation()
        move.translation = (x, y, 0)
        label = coin.SoText2()
        label.string = text
        label.justification = coin.SoText2.RIGHT
        sep.addChild(move)
        sep.addChild(label)
        self._labels.addChild(sep)

    def show(self, visible):
        """Show or hide the legend (call update() before the first show)."""
        self.node.whichChild = 0 if visible else coin.SO_SWITCH_NONE
