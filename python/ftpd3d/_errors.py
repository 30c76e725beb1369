"""The exceptions ftpd3d raises. Each is an ``ftpd3d.Error`` and also the built-in exception a
caller would catch for that kind of failure (``FileNotFoundError``, ``ValueError``, ``OSError``,
``RuntimeError``), so ``except ValueError`` and ``except ftpd3d.Error`` both work. Messages name
the file, line, parameter or value, in the terms of this module's keyword arguments."""

import errno


class Error(Exception):
    """Base class of every error ftpd3d raises itself."""


class MissingFileError(Error, FileNotFoundError):
    """A scene, map or field file that does not exist (``filename`` holds its path)."""

    def __init__(self, message, filename=None):
        super().__init__(errno.ENOENT, message, filename)

    def __str__(self):
        return self.strerror


class SceneError(Error, ValueError):
    """A scene file (or a file it refers to) that cannot be loaded as it is: the message names the
    file and line; ``strict=True`` refuses what a tolerant load only warns about."""


class ParameterError(Error, ValueError):
    """A value that cannot run: a slice, plane, window, run length, light, budget or camera (the
    message names the keyword argument or the value)."""


class FormatError(Error, ValueError):
    """A file that is not a field ftpd3d wrote, a damaged one, or a field a format cannot hold."""


class FileError(Error, OSError):
    """Reading or writing a file failed (the message says which file and why)."""


class RunError(Error, RuntimeError):
    """The run itself failed (Embree, the thread pool)."""
