"""Mount TOML files (schema in `kinsync.mount`)."""

from __future__ import annotations

from pathlib import Path

from kinsync.errors import InputError
from kinsync.io.atomic import atomic_write_text
from kinsync.mount import Mount, mount_from_toml_text, mount_to_toml_text

__all__ = ["read_mount", "write_mount"]


def read_mount(path: Path) -> Mount:
    """Read a mount TOML file; errors name the file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError as err:
        msg = f"{path}: mount file not found"
        raise InputError(msg) from err
    except (OSError, UnicodeDecodeError) as err:
        msg = f"{path}: cannot read mount file ({err})"
        raise InputError(msg) from err
    return mount_from_toml_text(text, source=str(path))


def write_mount(mount: Mount, path: Path) -> None:
    """Write a mount TOML file atomically."""
    atomic_write_text(Path(path), mount_to_toml_text(mount))
