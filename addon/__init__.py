"""Emotive Lip Sync: a Blender extension that turns recorded dialogue into
emotional, coarticulated shape-key animation.

The package has two halves: :mod:`.engine`, plain Python with no Blender
import (``python -m addon analyze ...`` runs it from a shell), and the Blender
glue, imported only when Blender registers the extension.
"""


def register():
    from .blender import register as _register

    _register()


def unregister():
    from .blender import unregister as _unregister

    _unregister()
