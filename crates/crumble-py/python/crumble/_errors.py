"""The exceptions crumble raises.

``CrumbleError`` is the base of every error of the engine's own;
``SceneError`` is also a ``ValueError`` (a scene is a value that is wrong),
and carries where the scene is wrong.
"""

from __future__ import annotations

__all__ = ["CrumbleError", "SceneError", "StepError", "PanicError"]


class CrumbleError(Exception):
    """An error of crumble: the base of the others."""


class SceneError(CrumbleError, ValueError):
    """A scene that cannot be loaded: unknown name, unreadable file, bad TOML,
    a value out of range, overlapping bodies.

    ``str(e)`` is the engine's message, ``file:line:column: `key`: what``,
    exactly as ``crumble run`` prints it. The parts:

    - ``file``: the file name (a path, ``scenes/NAME.toml (built-in)``, or
      ``<string>`` / the ``file_name`` given for TOML text);
    - ``line``, ``column``: 1-based, 0 when the error has no place (a file
      that does not exist);
    - ``key``: the dotted key path, e.g. ``wall[0].brick`` (empty when none);
    - ``message``: what is wrong.
    """

    def __init__(
        self,
        text: str,
        file: str = "",
        line: int = 0,
        column: int = 0,
        key: str = "",
        message: str = "",
    ) -> None:
        super().__init__(text)
        self.file = file
        self.line = line
        self.column = column
        self.key = key
        self.message = message or text


class StepError(CrumbleError):
    """The engine refused a step (e.g. a setting out of range); the message
    gives the step, the time and the engine's reason."""


class PanicError(CrumbleError):
    """The engine panicked: a bug in crumble, caught before it could abort
    Python. The world that panicked refuses every later step."""
