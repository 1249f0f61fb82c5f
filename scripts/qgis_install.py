"""Install fotogeo into a QGIS profile, ready to run: ``make qgis-install QGIS_PROFILE=<profile folder>``.

    /usr/bin/python3 scripts/qgis_install.py [--profile DIR] [--runtime DIR]

1. writes the plugin (the files of ``dist/fotogeo_qgis.zip``, see build_plugin.py) into
   ``<profile>/python/plugins/fotogeo_qgis`` (an older copy is replaced);
2. creates or repairs fotogeo's runtime — a venv of its own with binary wheels only, no
   compiler, no sudo (``<profile>/python/fotogeo-env``, or ``--runtime``; why a separate
   environment: ``processing_provider/runtime.py``) — and checks it;
3. enables the plugin (and Processing) in the profile's ``QGIS/QGIS3.ini`` and records a
   ``--runtime`` folder there (setting ``fotogeo/runtime``).

Standard library only; the default profile is ``~/.local/share/QGIS/QGIS3/profiles/default``.
For a separate settings tree (tests, CI) give ``--profile <QGIS_CUSTOM_CONFIG_PATH>/profiles/default``.
"""
from __future__ import annotations

import argparse
import importlib.util
import shutil
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from build_plugin import PLUGIN, plugin_files  # noqa: E402

DEFAULT_PROFILE = Path.home() / ".local/share/QGIS/QGIS3/profiles/default"


def write_plugin(profile: Path) -> Path:
    """The plugin's files into ``<profile>/python/plugins/fotogeo_qgis`` (written aside, then swapped in)."""
    plugins = profile / "python" / "plugins"
    plugins.mkdir(parents=True, exist_ok=True)
    staging = plugins / f".{PLUGIN}.new"
    shutil.rmtree(staging, ignore_errors=True)
    for name, data in plugin_files():
        path = staging / Path(name).relative_to(PLUGIN)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    target = plugins / PLUGIN
    if target.exists():
        old = plugins / f".{PLUGIN}.old"
        shutil.rmtree(old, ignore_errors=True)
        target.rename(old)
        staging.rename(target)
        shutil.rmtree(old, ignore_errors=True)
    else:
        staging.rename(target)
    return target


def installed_runtime_module(plugin: Path):
    """``processing_provider.runtime`` of the installed copy (so its checks run the plugin's own fotogeo)."""
    spec = importlib.util.spec_from_file_location("fotogeo_qgis_runtime", plugin / "processing_provider" / "runtime.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look the module up while building the class
    spec.loader.exec_module(module)
    return module


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profile", type=Path, default=DEFAULT_PROFILE, help="QGIS profile folder [%(default)s]")
    ap.add_argument("--runtime", type=Path, help="fotogeo's runtime folder [<profile>/python/fotogeo-env]")
    args = ap.parse_args(argv)
    profile = args.profile.expanduser().resolve()
    plugin = write_plugin(profile)
    print(f"fotogeo: plugin written to {plugin}")
    rt = installed_runtime_module(plugin)
    runtime = rt.resolve(profile, str(args.runtime.expanduser().resolve()) if args.runtime else None)
    print(f"fotogeo: building the runtime {runtime.folder} (pip, binary wheels only; a few minutes the first time)")
    last = [-1]

    def progress(fraction, message):
        if int(fraction * 10) != last[0]:
            last[0] = int(fraction * 10)
            print(f"fotogeo: {100 * fraction:3.0f} % {message}", flush=True)
        return True

    try:
        check = rt.install(runtime, log=lambda line: None, progress=progress)
    except rt.RuntimeInstallError as e:
        print(f"Error: {e}", file=sys.stderr)
        return 2
    ini = profile / "QGIS" / "QGIS3.ini"
    rt.set_ini_value(ini, "PythonPlugins", PLUGIN, "true")
    rt.set_ini_value(ini, "PythonPlugins", "processing", "true")
    if args.runtime:
        rt.set_ini_value(ini, "fotogeo", "runtime", str(runtime.folder))
    print(f"fotogeo: runtime ready ({rt.describe_libraries(check)}); plugin enabled in {ini}")
    print("fotogeo: start QGIS (with this profile) and open Processing > Toolbox > fotogeo")
    return 0


if __name__ == "__main__":
    sys.exit(main())
