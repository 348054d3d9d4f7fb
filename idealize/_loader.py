"""Finds the compiled core and explains what to do when it is missing."""
try:
    from . import _native  # noqa: F401  (re-exported)
except ImportError as error:  # pragma: no cover - only without a build
    raise ImportError(
        "Idealize's native core is not built (or was built for another Python). "
        "Run the set-up command from the README (tools/setup.sh), which builds it for "
        "/usr/bin/python3, the interpreter FreeCAD uses. Original error: %s" % error
    ) from error

native = _native
