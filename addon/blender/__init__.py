"""The Blender side of the extension: properties, operators, the sidebar
panel and the ``--command lipsync`` batch entry.  All the lip-sync work is
done by :mod:`..engine`; this package reads and writes Blender data."""

from __future__ import annotations

import bpy

from . import command, edits_ui, gestures_ui, learning, operators, panel, preset_ui, props

_classes = (operators.classes + learning.classes + preset_ui.classes + panel.classes + edits_ui.classes
            + gestures_ui.classes)
_cli_handle = None


def register():
    global _cli_handle
    props.register()
    for c in _classes:
        bpy.utils.register_class(c)
    if hasattr(bpy.utils, "register_cli_command"):
        _cli_handle = bpy.utils.register_cli_command(command.COMMAND, command.execute)


def unregister():
    global _cli_handle
    if _cli_handle is not None:
        bpy.utils.unregister_cli_command(_cli_handle)
        _cli_handle = None
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
    props.unregister()
