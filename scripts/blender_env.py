"""Run the *installed* extension inside Blender's Python module (the ``bpy`` wheel), isolated.

Shared by ``./fh``, ``make install``, ``make demo`` and the test harness so all of them load the
extension exactly the way a Blender user gets it: the built zip, installed into a user folder of its
own (never the real Blender config), then enabled.

Blender reads ``BLENDER_USER_RESOURCES`` once, when ``bpy`` is first imported, so :func:`use_user_dir`
must run before anything imports ``bpy``.
"""
from __future__ import annotations

import json
import os
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXTENSION_ID = "faces_hands"
REPO = "user_default"
MODULE = f"bl_ext.{REPO}.{EXTENSION_ID}"


def manifest_version() -> str:
    import tomllib
    return tomllib.loads((ROOT / "blender_manifest.toml").read_text())["version"]


def built_zip() -> Path:
    """The zip `make build` makes for this interpreter's Python line, for Linux x64."""
    from build_ext import line_of_python, zip_name
    return ROOT / "dist" / zip_name(manifest_version(), line_of_python(), "linux-x64")


def use_user_dir(user_dir: Path) -> None:
    """Point Blender's user resources at ``user_dir``; must precede ``import bpy``."""
    if "bpy" in sys.modules:
        current = os.environ.get("BLENDER_USER_RESOURCES")
        if current and Path(current) == Path(user_dir):
            return
        raise RuntimeError("bpy is already imported; the user folder can no longer change")
    user_dir.mkdir(parents=True, exist_ok=True)
    os.environ["BLENDER_USER_RESOURCES"] = str(user_dir)


def extension_dir(user_dir: Path) -> Path:
    return user_dir / "extensions" / REPO / EXTENSION_ID


def wheel_site_packages(user_dir: Path) -> Path:
    major, minor = sys.version_info[:2]
    return user_dir / "extensions" / ".local" / "lib" / f"python{major}.{minor}" / "site-packages"


def _quiet_bpy():
    import bpy  # noqa: F401  (first import prints Blender's start-up lines)
    return bpy


def install(zip_path: Path, user_dir: Path) -> None:
    """Install ``zip_path`` into ``user_dir`` (replacing an older install) and enable it."""
    use_user_dir(user_dir)
    bpy = _quiet_bpy()
    result = bpy.ops.extensions.package_install_files(
        filepath=str(zip_path), repo=REPO, enable_on_install=True, overwrite=True)
    if result != {"FINISHED"}:
        raise RuntimeError(f"installing {zip_path} failed: {result}")
    stamp = {"zip": str(zip_path), "mtime": zip_path.stat().st_mtime, "size": zip_path.stat().st_size}
    (user_dir / "faces_hands_install.json").write_text(json.dumps(stamp))
    bpy.ops.wm.save_userpref()


def is_current(zip_path: Path, user_dir: Path) -> bool:
    stamp_path = user_dir / "faces_hands_install.json"
    if not (stamp_path.exists() and zip_path.exists() and extension_dir(user_dir).exists()):
        return False
    stamp = json.loads(stamp_path.read_text())
    return stamp.get("mtime") == zip_path.stat().st_mtime and stamp.get("size") == zip_path.stat().st_size


def enable(user_dir: Path, quiet: bool = False):
    """Import ``bpy`` against ``user_dir`` and make sure the installed extension is enabled.
    ``quiet`` sends Blender's start-up chatter to stderr, keeping stdout for the caller's output."""
    if quiet:
        stdout_fd = os.dup(1)
        os.dup2(2, 1)
        try:
            return enable(user_dir)
        finally:
            sys.stdout.flush()
            os.dup2(stdout_fd, 1)
            os.close(stdout_fd)
    use_user_dir(user_dir)
    _quiet_bpy()  # bpy must be imported before addon_utils
    import addon_utils
    if MODULE not in sys.modules or not getattr(sys.modules[MODULE], "_registered", False):
        addon_utils.enable(MODULE, default_set=True, handle_error=_raise)
    return sys.modules[MODULE]


def alias_installed_engine() -> None:
    """Make ``import faces_hands_addon.x`` return the installed extension's own module objects
    (``bl_ext.user_default.faces_hands.faces_hands_addon.x``), so tests and benchmarks exercise
    exactly what a user installed, never the source tree."""
    import importlib
    import pkgutil
    installed = f"{MODULE}.faces_hands_addon"
    package = importlib.import_module(installed)
    sys.modules["faces_hands_addon"] = package
    for info in pkgutil.walk_packages(package.__path__, prefix=installed + "."):
        module = importlib.import_module(info.name)
        sys.modules["faces_hands_addon" + info.name[len(installed):]] = module


def _wheel_fits(name: str) -> bool:
    """Does wheel file ``name`` install on this interpreter (Linux x64, this CPython line)?"""
    import platform
    parts = name[:-len(".whl")].split("-")
    python_tag, platform_tag = parts[-3], parts[-1]
    line = f"cp{sys.version_info[0]}{sys.version_info[1]}"
    python_ok = any(tag in (line, "py3", "py2") for tag in python_tag.split("."))
    machine = platform.machine().lower()
    platform_ok = platform_tag == "any" or (sys.platform.startswith("linux") and "linux" in platform_tag
                                            and machine in platform_tag)
    return python_ok and platform_ok


def unpack(zip_path: Path, folder: Path) -> tuple[Path, Path]:
    """Unpack the built extension without Blender: its files into ``folder/faces_hands`` and the wheels
    that fit this interpreter into ``folder/site-packages`` (what Blender's installer would do). Returns
    both folders; put them on ``sys.path`` to import ``faces_hands_addon`` as shipped."""
    import io
    import zipfile
    extension, site = folder / EXTENSION_ID, folder / "site-packages"
    site.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(zip_path) as archive:
        for name in archive.namelist():
            if name.endswith(".whl"):
                if _wheel_fits(Path(name).name):
                    with zipfile.ZipFile(io.BytesIO(archive.read(name))) as wheel:
                        wheel.extractall(site)
            else:
                archive.extract(name, extension)
    return extension, site


def _raise(exc):
    raise exc


def fresh_user_dir(user_dir: Path) -> Path:
    if user_dir.exists():
        shutil.rmtree(user_dir)
    user_dir.mkdir(parents=True)
    return user_dir
