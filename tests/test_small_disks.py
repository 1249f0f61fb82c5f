"""A small disk is not a full one: a refused write on a read-only (and tiny) file system says so, and the
free-space pre-check does not refuse a small output on a small disk."""
from __future__ import annotations

import errno
import os
import shutil
import subprocess
from collections import namedtuple

import pytest
from click.testing import CliRunner

import fotogeo
from fotogeo.cli import main
from fotogeo.errors import OutputError
from fotogeo.io import output_checks
from test_bad_input import _failing_json, assert_one_line_error, env, out  # noqa: F401 (fixtures)

Usage = namedtuple("Usage", "total used free")


@pytest.mark.parametrize("code", [errno.EROFS, errno.EACCES])
def test_a_refused_write_on_a_small_disk_is_not_a_full_disk(env, out, monkeypatch, code):  # noqa: F811
    import fotogeo.tools.common.boundary as boundary
    import fotogeo.tools.orient.tool as orient_tool
    monkeypatch.setattr(boundary, "_free_bytes", lambda folder: 300 * 1024)  # a tiny disk
    monkeypatch.setattr(orient_tool, "write_json",
                        _failing_json(lambda p: OSError(code, os.strerror(code), str(p))))
    with pytest.raises(OutputError) as info:
        fotogeo.orient(env["dir"] / "target.tif", env["dir"] / "gcps.gpkg", report=out / "r.json")
    text = str(info.value)
    assert "permission denied" in text and "disk full" not in text, text


def test_the_space_check_refuses_only_clearly_too_little(tmp_path, monkeypatch):
    monkeypatch.setattr(shutil, "disk_usage", lambda folder: Usage(6 * 2 ** 20, 2 ** 20, 5 * 2 ** 20))
    # 5 MB free: fine
    output_checks.check_space(tmp_path, output_checks.grid_bytes(1000, 500, 3, "uint8"), "a 2 MB orthophoto")
    with pytest.raises(OutputError, match="5 MB free, about 26 MB needed"):
        output_checks.check_space(tmp_path, 100 * 2 ** 20, "a 100 MB orthophoto")


def test_the_space_check_of_an_uncompressed_output_needs_its_whole_size(tmp_path, monkeypatch):
    """12 MB written with DEFLATE fits in 5 MB free (a quarter: 3 MB + 1 MB); written with --compress none it does
    not (12 MB + 1 MB)."""
    monkeypatch.setattr(shutil, "disk_usage", lambda folder: Usage(6 * 2 ** 20, 2 ** 20, 5 * 2 ** 20))
    output_checks.check_space(tmp_path, 12 * 2 ** 20, "a 12 MB orthophoto")
    output_checks.check_space(tmp_path, 12 * 2 ** 20, "a 12 MB orthophoto", "zstd")
    with pytest.raises(OutputError, match="5 MB free, about 13 MB needed"):
        output_checks.check_space(tmp_path, 12 * 2 ** 20, "a 12 MB orthophoto", "none")


@pytest.fixture
def read_only_tiny(tmp_path):
    """A 600 kB tmpfs mounted read-only (root and mount needed; skipped otherwise)."""
    folder = tmp_path / "ro"
    folder.mkdir()
    if os.geteuid() != 0 or not shutil.which("mount"):
        pytest.skip("a read-only file system needs root to mount a small tmpfs")
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=600k,ro", "tmpfs", str(folder)],
                      capture_output=True).returncode != 0:
        pytest.skip("mounting a small tmpfs is not allowed here")
    try:
        yield folder
    finally:
        subprocess.run(["umount", str(folder)], check=False)


def test_real_read_only_tiny_file_system(env, read_only_tiny):  # noqa: F811
    result = CliRunner().invoke(main, ["fuse", str(env["dir"] / "target.tif"), "-o", str(read_only_tiny / "f.tif"),
                                       "-q"])
    assert_one_line_error(result, "not writable")
    assert "disk full" not in result.stderr and "Read-only file system" in result.stderr


@pytest.mark.parametrize("compress", ["zstd", "lzw"])
def test_the_space_check_takes_the_ratio_of_the_compression_asked(tmp_path, monkeypatch, compress):
    """ZSTD (level 1) and LZW compress orthophotos less than DEFLATE: 76 MB fits in 20.5 MB free with DEFLATE
    (76 / 4 + 1 = 20 MB), not with zstd or lzw (76 / 3.8 + 1 = 21 MB)."""
    monkeypatch.setattr(shutil, "disk_usage", lambda folder: Usage(30 * 2 ** 20, 2 ** 20, int(20.5 * 2 ** 20)))
    output_checks.check_space(tmp_path, 76 * 2 ** 20, "a 76 MB orthophoto", "deflate")
    with pytest.raises(OutputError, match="about 21 MB needed"):
        output_checks.check_space(tmp_path, 76 * 2 ** 20, "a 76 MB orthophoto", compress)
