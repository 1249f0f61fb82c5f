"""Camera and option YAML through PyYAML (fotogeo/io/yaml_file.py): what YAML allows is read, problems are one line."""
from __future__ import annotations

import pytest

from fotogeo.errors import InputError
from fotogeo.io.camera import read_camera_with_distortion, read_interior_orientation
from fotogeo.io.yaml_file import read_yaml_mapping, yaml_key

FLOW = "cam:\n  type: pinhole\n  im_size: [5472, 3648]\n  focal_len: 8.8\n  sensor_size: [13.2, 8.8]\n"


def _cam(tmp_path, text, name="io.yaml"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return read_interior_orientation(p)


def test_block_lists_read_like_flow_lists(tmp_path):
    block = ("cam:\n  type: pinhole\n  im_size:\n    - 5472\n    - 3648\n  focal_len: 8.8\n"
             "  sensor_size:\n  - 13.2\n  - 8.8\n")
    a, b = _cam(tmp_path, FLOW, "a.yaml")["cam"], _cam(tmp_path, block, "b.yaml")["cam"]
    assert a.image_size == b.image_size == (5472, 3648) and a.sensor_size == b.sensor_size == (13.2, 8.8)


def test_document_start_and_comments(tmp_path):
    cam = _cam(tmp_path, "%YAML 1.1\n---\n# a drone camera\n" + FLOW + "...\n")["cam"]
    assert cam.focal_length == 8.8


def test_quoted_key_with_colon_is_one_camera(tmp_path):
    """The hand parser split ``'DJI FC6310: 8.8mm':`` at its first colon; YAML reads the whole quoted key."""
    text = FLOW.replace("cam:", "'DJI FC6310: 8.8mm':")
    cams = _cam(tmp_path, text)
    assert list(cams) == ["DJI FC6310: 8.8mm"]
    double = _cam(tmp_path, FLOW.replace("cam:", '"Cam \\"A\\": 2":'), "d.yaml")
    assert list(double) == ['Cam "A": 2']


def test_written_camera_names_read_back(tmp_path):
    """fotogeo's own camera.yaml quotes a name only when YAML needs it, and reads it back as written."""
    from fotogeo.geometry.camera import FrameCamera
    from fotogeo.io.block import write_interior_orientation
    cam = FrameCamera(8.8, (13.2, 8.8), (5472, 3648), (2740.0, 1822.5))
    for name in ("DJI FC6310: 8.8mm", "plain_cam", "1", "yes", "true", "Kamera ü", "#1", "- x", "a\\b"):
        p = tmp_path / "c.yaml"
        write_interior_orientation(p, name, cam, {"k1": 1e-5, "k2": 0.0, "p1": 0.0, "p2": 0.0, "k3": 0.0})
        back, dist = read_camera_with_distortion(p)
        assert list(read_yaml_mapping(p.read_text())[0]) == [name], (name, p.read_text())
        assert back.principal_point == pytest.approx(cam.principal_point) and dist["k1"] == 1e-5
    assert yaml_key("plain_cam") == "plain_cam" and yaml_key("a: b") == '"a: b"'


def test_core_schema_scalars():
    """YAML 1.2 numbers and booleans: 1e-5 is a number, 0700 is 700, yes/no/on are text."""
    data, lines = read_yaml_mapping("k1: 1e-5\nk2: -2.5E+3\nn: 0700\nyes: on\nflag: true\nnan: .nan\n")
    assert data == {"k1": 1e-5, "k2": -2500.0, "n": 700, "yes": "on", "flag": True, "nan": data["nan"]}
    assert data["nan"] != data["nan"] and lines == {"k1": 1, "k2": 2, "n": 3, "yes": 4, "flag": 5, "nan": 6}
    data, lines = read_yaml_mapping("fiducials_mm:\n  1: [-106.0, 106.0]\n  2: [106.0, 106.0]\n")
    assert list(data["fiducials_mm"]) == ["1", "2"]  # ids are names


@pytest.mark.parametrize("text, message", [
    ("cam: [1, 2\n", "line 2: not valid YAML"),
    ("cam:\n\ttype: pinhole\n", "indent with spaces, not tabs"),
    ("- a\n- b\n", "line 1: expected 'key: value' lines at the top level, got a list"),
    ("just text\n", "got a single value"),
    ("a: 1\n---\nb: 2\n", "line 2: holds a second YAML document"),
    ("cam: 1\nother: 2\ncam: 3\n", "line 3: 'cam' is given twice (first on line 1)"),
    ("cam:\n  im_size: " + "[" * 3000 + "1" + "]" * 3000 + "\n", "line 2: im_size: a list nested 3000 deep"),
    ("cam:\n  im_size:\n    - - - 1\n", "line 1: cam: lists nested 3 deep"),
    ("a: !!python/object:os.system ls\n", "not valid YAML"),
])
def test_problems_are_one_line_naming_the_file_and_line(text, message):
    with pytest.raises(InputError) as e:
        read_yaml_mapping(text, "camera 'x.yaml', ")
    assert str(e.value).startswith("camera 'x.yaml', ") and message in str(e.value) and "\n" not in str(e.value)


def test_empty_file_has_no_camera(tmp_path):
    assert read_yaml_mapping("") == ({}, {}) and read_yaml_mapping("# nothing\n---\n") == ({}, {})
    (tmp_path / "e.yaml").write_text("---\n")
    with pytest.raises(InputError, match="defines no camera"):
        read_camera_with_distortion(tmp_path / "e.yaml")
