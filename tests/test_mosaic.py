"""fotogeo mosaic (issue 21): two orthophotos of one textured scene with a planted radiometric step and a
"building" that looks different in each (as a leaning roof does): balancing removes the step, the seam goes
around the building, the seamlines layer is written; bad input is one Error line."""
from __future__ import annotations

import numpy as np
import pytest
import rasterio
from affine import Affine
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.tools.ortho.mosaic import mosaic
from test_bad_input import assert_one_line_error

X0, Y1 = 500000.0, 4400000.0
BOX = (230.0, 250.0, 80.0, 110.0)  # x0, x1, y0, y1 (m from the scene origin), across the Voronoi boundary x = 240
GAIN, OFFSET = 1.3, 20.0  # the radiometric step planted in the second orthophoto
BOX_ROWS, BOX_COLS = slice(40, 55), slice(115, 125)  # the box on the 2-m DSM grid


def texture(x, y):
    return 85 + 30 * np.sin(x / 6.0) * np.cos(y / 8.0) + 20 * np.sin((x + 2 * y) / 11.0)


def _ortho(path, x0, x1, nadir_x, gain=1.0, offset=0.0, box_value=None):
    w, h = int(x1 - x0), 200
    t = Affine(1.0, 0, X0 + x0, 0, -1.0, Y1)
    c, r = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    x, y = c + x0, r  # metres east of the origin, south of the top
    v = gain * texture(x, y) + offset
    inside = (x > BOX[0]) & (x < BOX[1]) & (y > BOX[2]) & (y < BOX[3])
    if box_value is not None:
        v[inside] = box_value
    with rasterio.open(path, "w", driver="GTiff", width=w, height=h, count=1, dtype="uint8", crs="EPSG:32635",
                       transform=t, nodata=0) as ds:
        ds.write(np.clip(np.rint(v), 1, 255).astype(np.uint8), 1)
        ds.update_tags(FOTOGEO_NADIR=f"{X0 + nadir_x} {Y1 - 100}")
    return path


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    d = tmp_path_factory.mktemp("mosaic")
    return (_ortho(d / "a.tif", 0, 300, 150, box_value=240),
            _ortho(d / "b.tif", 180, 480, 330, GAIN, OFFSET, box_value=30))


def _read(path):
    with rasterio.open(path) as ds:
        return ds.read(1).astype(float), ds.transform


def test_balancing_removes_the_step(pair, tmp_path):
    rep = mosaic([str(p) for p in pair], str(tmp_path / "m.tif"))
    (ga,), (gb,) = rep["gains"]
    (oa,), (ob,) = rep["offsets"]
    a, ta = _read(pair[0])
    b, tb = _read(pair[1])
    cols = slice(180, 300)  # the overlap in a's columns; b's columns 0..120
    x = np.arange(180, 300) + 0.5
    y = np.arange(200) + 0.5
    off_box = ~((x[None, :] > BOX[0] - 2) & (x[None, :] < BOX[1] + 2) & (y[:, None] > BOX[2] - 2) &
                (y[:, None] < BOX[3] + 2))
    before = np.abs(a[:, cols] - b[:, :120])[off_box].mean()
    after = np.abs(ga * a[:, cols] + oa - (gb * b[:, :120] + ob))[off_box].mean()
    assert before > 20 and after * 5 <= before, (before, after)
    m, tm = _read(tmp_path / "m.tif")
    far_a = np.abs(m[:, 20:120] - np.clip(np.rint(ga * a[:, 20:120] + oa), 1, 255)).max()
    assert far_a <= 1  # away from the seam the mosaic is the balanced first orthophoto
    assert m.shape == (200, 480) and (m > 0).all()


def test_seam_goes_around_the_building(pair, tmp_path):
    import geopandas as gpd
    import shapely
    rep = mosaic([str(p) for p in pair], str(tmp_path / "m.tif"), seamlines=str(tmp_path / "s.gpkg"))
    regions = gpd.read_file(tmp_path / "s.gpkg", layer="regions")
    seams = gpd.read_file(tmp_path / "s.gpkg", layer="seamlines")
    box = shapely.box(X0 + BOX[0], Y1 - BOX[3], X0 + BOX[1], Y1 - BOX[2])
    assert len(seams) >= 1 and set(seams.iloc[0][["image_a", "image_b"]]) == {"a", "b"}
    assert not seams.geometry.intersects(box.buffer(-0.5)).any()  # no seam crosses the building
    owner = [r.geometry.buffer(0.01).contains(box.buffer(-0.5)) for r in regions.itertuples()]
    assert sum(owner) == 1, owner  # the building comes whole from one orthophoto
    assert rep["cells_per_image"][0] > 0 and rep["cells_per_image"][1] > 0


def test_dsm_keeps_seams_off_buildings(tmp_path):
    """Two orthophotos that agree everywhere (no grey difference to steer the seam) and a DSM with a 12 m high
    block across the Voronoi boundary: with the DSM the seam goes around the block, without it straight through."""
    import geopandas as gpd
    import shapely
    a = _ortho(tmp_path / "a.tif", 0, 300, 150, box_value=None)
    b = _ortho(tmp_path / "b.tif", 180, 480, 330, box_value=None)
    with rasterio.open(tmp_path / "dsm.tif", "w", driver="GTiff", width=240, height=100, count=1, dtype="float32",
                       crs="EPSG:32635", transform=Affine(2.0, 0, X0, 0, -2.0, Y1)) as ds:
        z = np.full((100, 240), 300.0, np.float32)
        z[BOX_ROWS, BOX_COLS] = 312.0
        ds.write(z, 1)
    box = shapely.box(X0 + BOX[0], Y1 - BOX[3], X0 + BOX[1], Y1 - BOX[2]).buffer(-0.5)
    crossed = {}
    for name, dsm in (("with", str(tmp_path / "dsm.tif")), ("without", None)):
        mosaic([str(a), str(b)], str(tmp_path / f"{name}.tif"), dsm=dsm)
        seams = gpd.read_file(tmp_path / f"{name}.gpkg", layer="seamlines")
        crossed[name] = bool(seams.geometry.intersects(box).any())
    assert crossed == {"with": False, "without": True}


def _ortho_on(path, x0, x1, pixel, shift, gain=1.0, offset=0.0, crs="EPSG:32635"):
    """The scene's texture between ``x0`` and ``x1`` (m) on a grid of ``pixel`` metres whose origin is ``shift``
    metres off the whole-metre lattice of :func:`_ortho` (as frames registered to neighbouring reference tiles)."""
    w, h = int((x1 - x0) / pixel), int(200 / pixel)
    t = Affine(pixel, 0, X0 + x0 + shift, 0, -pixel, Y1 - shift)
    c, r = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    v = gain * texture(c * pixel + x0 + shift, r * pixel + shift) + offset
    with rasterio.open(path, "w", driver="GTiff", width=w, height=h, count=1, dtype="uint8", crs=crs,
                       transform=t, nodata=0) as ds:
        ds.write(np.clip(np.rint(v), 1, 255).astype(np.uint8), 1)
    return path


def test_orthophotos_on_other_lattices_are_resampled_onto_the_finest(pair, tmp_path):
    """A neighbour on a 1.25 m grid shifted 0.3 m (another reference tile's lattice) is resampled on the fly onto
    the finest lattice (1 m, the first's): its part of the mosaic keeps its values (bilinear on a smooth texture)
    and the run says which file was resampled."""
    b = _ortho_on(tmp_path / "coarse.tif", 180, 480, 1.25, 0.3, GAIN, OFFSET)
    rep = mosaic([str(pair[0]), str(b)], str(tmp_path / "m.tif"), balance=False)
    assert rep["resampled_onto_lattice"] == ["coarse.tif"]
    m, t = _read(tmp_path / "m.tif")
    assert (t.a, t.e) == (1.0, -1.0) and ((t.c - X0) % 1.0, (t.f - Y1) % 1.0) == (0.0, 0.0)
    c, r = np.meshgrid(np.arange(m.shape[1]) + 0.5, np.arange(m.shape[0]) + 0.5)
    x, y = c + (t.c - X0), r + (Y1 - t.f)
    only_b = (x > 340) & (x < 470) & (y > 5) & (y < 190)
    err = np.abs(m - np.clip(np.rint(GAIN * texture(x, y) + OFFSET), 1, 255))[only_b]
    assert np.median(err) <= 1.0 and np.percentile(err, 99) <= 4.0, (np.median(err), np.percentile(err, 99))


def test_another_crs_is_refused(pair, tmp_path):
    b = _ortho_on(tmp_path / "other.tif", 180, 480, 1.0, 0.0, crs="EPSG:32634")
    out = tmp_path / "m.tif"
    result = CliRunner().invoke(main, ["mosaic", str(pair[0]), str(b), "-o", str(out), "-q"])
    assert_one_line_error(result, "is in another CRS")
    assert not out.exists() and not list(tmp_path.glob("m.*"))


def test_ngi_frames_mosaic_on_the_orthophoto(data_dir, tmp_path):
    """The two NGI frames orthorectified (camera, EO, DEM) and mosaicked: one seamline between them, gains near 1
    (the same camera and flight), and the mosaic lands on the published orthophoto (median tile shift well under a
    pixel, as each frame does)."""
    import cv2
    from rasterio.warp import Resampling, reproject

    from fotogeo.tools.ortho.tool import ortho
    ngi = data_dir / "ngi"
    frames = sorted(str(p) for p in (ngi / "frames").glob("*.tif"))
    ortho(frames, str(tmp_path / "orthos"), dem=str(ngi / "dem.tif"), camera=str(ngi / "interior_orientation.yaml"),
          eo=str(ngi / "exterior_orientation.txt"), resolution=5.0, resampling="bilinear")
    rep = mosaic(sorted(str(p) for p in (tmp_path / "orthos").glob("*.tif")), str(tmp_path / "m.tif"))
    assert all(0.9 < g < 1.1 for gains in rep["gains"] for g in gains)
    import geopandas as gpd
    assert len(gpd.read_file(tmp_path / "m.gpkg", layer="seamlines")) == 1
    with rasterio.open(tmp_path / "m.tif") as ds:
        ours, prof = ds.read(1).astype(np.float32), ds.profile
    ref = np.zeros_like(ours)
    with rasterio.open(ngi / "ortho" / "ngi_rgb_byte_1.tif") as ds:
        reproject(rasterio.band(ds, 1), ref, dst_transform=prof["transform"], dst_crs=prof["crs"],
                  resampling=Resampling.bilinear, dst_nodata=0)
    hann = cv2.createHanningWindow((128, 128), cv2.CV_32F)
    valid = (ours > 0) & (ref > 0)
    shifts = [cv2.phaseCorrelate(ours[i:i + 128, j:j + 128], ref[i:i + 128, j:j + 128], hann)[0]
              for i in range(0, ours.shape[0] - 127, 128) for j in range(0, ours.shape[1] - 127, 128)
              if valid[i:i + 128, j:j + 128].all()]
    assert len(shifts) >= 15
    assert np.median(np.hypot(*np.array(shifts).T)) < 0.6


def _grid_of_orthos(folder, rows=3, cols=4, side=120, step=90):
    """``rows x cols`` orthophotos of one texture, ``side`` pixels, ``step`` apart, each with its own gain."""
    rng = np.random.default_rng(3)
    paths = []
    for i in range(rows):
        for j in range(cols):
            x0, y0 = j * step, i * step
            c, r = np.meshgrid(np.arange(side) + 0.5 + x0, np.arange(side) + 0.5 + y0)
            v = rng.uniform(0.85, 1.15) * texture(c, r) + rng.uniform(-10, 10)
            p = folder / f"o_{i}_{j}.tif"
            with rasterio.open(p, "w", driver="GTiff", width=side, height=side, count=1, dtype="uint8",
                               crs="EPSG:32635", transform=Affine(1.0, 0, X0 + x0, 0, -1.0, Y1 - y0), nodata=0) as ds:
                ds.write(np.clip(np.rint(v), 1, 255).astype(np.uint8), 1)
            paths.append(str(p))
    return paths


def test_tiles_assemble_into_one_cog(tmp_path, monkeypatch):
    """Twelve orthophotos in a 3 x 4 grid: the mosaic written in 128-pixel tiles (VRT -> COG) equals the one written
    in a single tile; only neighbours are compared (29 overlapping pairs of 66: 9 + 8 side by side, 12 diagonal),
    every image keeps a region, and the COG is tiled with overviews."""
    import fotogeo.tools.ortho.mosaic_tiles as mt
    paths = _grid_of_orthos(tmp_path)
    one = mosaic(paths, str(tmp_path / "one.tif"))
    monkeypatch.setattr(mt, "TILE", 128)
    many = mosaic(paths, str(tmp_path / "many.tif"))
    assert (one["tiles"], many["tiles"]) == (1, 12)
    assert many["overlapping_pairs"] == 29 and all(c > 0 for c in many["cells_per_image"])
    a, _ = _read(tmp_path / "one.tif")
    b, _ = _read(tmp_path / "many.tif")
    assert a.shape == (300, 390) and (a > 0).all() and np.array_equal(a, b)
    with rasterio.open(tmp_path / "many.tif") as ds:
        assert ds.overviews(1) and ds.profile["tiled"] and ds.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"


def test_tiles_on_a_local_dask_cluster(tmp_path, monkeypatch):
    """``workers=1``: the tiles run on a local Dask cluster (register-batch's mechanism) and give the same mosaic."""
    pytest.importorskip("distributed", reason="Dask (fotogeo[batch]) is not installed")
    import fotogeo.tools.ortho.mosaic_tiles as mt
    paths = _grid_of_orthos(tmp_path, rows=2, cols=2)
    monkeypatch.setattr(mt, "TILE", 128)
    threads = mosaic(paths, str(tmp_path / "threads.tif"))
    dask = mosaic(paths, str(tmp_path / "dask.tif"), workers=1)
    assert (threads["executor"], dask["executor"]) == ("threads", "dask") and dask["tiles"] == 4
    assert np.array_equal(_read(tmp_path / "threads.tif")[0], _read(tmp_path / "dask.tif")[0])


#: the rendered block's mosaic: output pixel (m) and phase-correlation tile (pixels)
TRUTH_PIXEL, TRUTH_TILE = 1.5, 64


def truth_shifts(mosaic_path, tex, tex_t, tile: int = TRUTH_TILE):
    """Shifts (pixels, ``(k, 2)``) between the mosaic and the true ground texture averaged onto its grid, by phase
    correlation on every ``tile``² tile the mosaic covers wholly."""
    import cv2
    from rasterio.warp import Resampling, reproject
    with rasterio.open(mosaic_path) as ds:
        ours, prof = ds.read(1).astype(np.float32), ds.profile
    truth = np.zeros_like(ours)
    reproject(tex, truth, src_transform=tex_t, src_crs="EPSG:32635", dst_transform=prof["transform"],
              dst_crs="EPSG:32635", resampling=Resampling.average)
    hann = cv2.createHanningWindow((tile, tile), cv2.CV_32F)
    return np.array([cv2.phaseCorrelate(ours[i:i + tile, j:j + tile], truth[i:i + tile, j:j + tile], hann)[0]
                     for i in range(0, ours.shape[0] - tile + 1, tile) for j in range(0, ours.shape[1] - tile + 1, tile)
                     if (ours[i:i + tile, j:j + tile] > 0).all()])


def rendered_block_mosaic(folder):
    """A rendered synthetic block (2 strips of 3 frames, terrain relief 40 m) orthorectified frame by frame with its
    true orientations on its true DEM and mosaicked; ``(report, block, ground texture, its transform)``."""
    from fotogeo.geometry.camera import FrameCamera
    from fotogeo.io.block import write_exterior_orientation, write_interior_orientation
    from fotogeo.orientation.block_render import ground_texture, render_block
    from fotogeo.orientation.block_simulation import simulate_block
    from fotogeo.tools.ortho.tool import ortho
    from rendered_block_ties import write_frames
    sb = simulate_block(seed=1, strips=2, frames_per_strip=3, camera=FrameCamera(6.0, (4.0, 6.0), (400, 600)),
                        point_spacing=80.0, blunder_fraction=0.0, margin=5.0)
    images, dem = render_block(sb)
    frames = write_frames(folder, sb, images)
    write_interior_orientation(folder / "camera.yaml", "camera", sb.true_camera)
    write_exterior_orientation(folder / "eo.txt", sb.block.frames, sb.true_eo)
    with rasterio.open(folder / "dem.tif", "w", driver="GTiff", width=dem.data.shape[1], height=dem.data.shape[0],
                       count=1, dtype="float32", crs="EPSG:32635", transform=dem.transform) as ds:
        ds.write(dem.data.astype(np.float32), 1)
    ortho([str(f) for f in frames], str(folder / "orthos"), dem=str(folder / "dem.tif"),
          camera=str(folder / "camera.yaml"), eo=str(folder / "eo.txt"), resolution=TRUTH_PIXEL,
          resampling="bilinear")
    rep = mosaic(sorted(str(p) for p in (folder / "orthos").glob("*.tif")), str(folder / "mosaic.tif"))
    return (rep, sb, *ground_texture(sb))


def test_rendered_block_mosaic_agrees_with_the_truth(tmp_path):
    """Issue 21: the mosaic of a rendered block (known truth) lands on the true ground texture: median and 95th
    percentile of the tile shifts <= 0.5 GSD of the frames; seamlines join the six frames, gains stay near 1 (the
    frames see one texture)."""
    rep, sb, tex, tex_t = rendered_block_mosaic(tmp_path)
    shifts = truth_shifts(tmp_path / "mosaic.tif", tex, tex_t)
    d = np.hypot(*shifts.T) * TRUTH_PIXEL / sb.gsd  # in GSDs of the frames
    assert len(shifts) >= 100
    assert np.median(d) <= 0.5 and np.percentile(d, 95) <= 0.5, (np.median(d), np.percentile(d, 95))
    assert rep["overlapping_pairs"] >= 7 and all(c > 0 for c in rep["cells_per_image"])
    assert all(0.9 < g < 1.1 for gains in rep["gains"] for g in gains)


def test_flipped_unreferenced_inputs_and_a_dsm_elsewhere_are_named(pair, tmp_path):
    """The sweep's cases (issue 32), each failing on main: a south-up orthophoto was refused naming a temporary
    VRT ('…/fotogeo-mosaic-…/1.vrt … Invalid dataset dimensions'); a PNG without georeference was 'in another
    CRS'; a DSM of another area left the seamlines as without it, exit 0, nothing said."""
    with rasterio.open(pair[1]) as ds:
        img, prof, t = ds.read(), ds.profile, ds.transform
    prof.update(transform=Affine(t.a, 0, t.c, 0, -t.e, t.f + t.e * img.shape[1]))
    with rasterio.open(tmp_path / "south up.tif", "w", **prof) as ds:
        ds.write(img[:, ::-1])
    png = tmp_path / "b.png"
    with rasterio.open(png, "w", driver="PNG", width=img.shape[2], height=img.shape[1], count=1, dtype="uint8") as ds:
        ds.write(img)
    with rasterio.open(tmp_path / "dsm.tif", "w", driver="GTiff", width=50, height=50, count=1, dtype="float32",
                       crs="EPSG:32635", transform=Affine(2.0, 0, X0 + 5000, 0, -2.0, Y1)) as ds:
        ds.write(np.full((1, 50, 50), 300.0, np.float32))
    out = tmp_path / "m.tif"
    for second, extra, words in ((tmp_path / "south up.tif", [], "south up.tif' is stored south-up"),
                                 (png, [], "b.png' has no georeference"),
                                 (pair[1], ["--dsm", str(tmp_path / "dsm.tif")], "covers none of the mosaic")):
        result = CliRunner().invoke(main, ["mosaic", str(pair[0]), str(second), "-o", str(out), "-q", *extra])
        assert_one_line_error(result, words)
        assert not out.exists() and not list(tmp_path.glob("m.*"))


@pytest.mark.parametrize("names,words", [(("m.jpg", None), "writes it as GeoTIFF; give a file name ending in .tif"),
                                         (("m.tif", "s.shp"), "writes it as GeoPackage; give a file name ending")])
def test_outputs_named_for_another_format_are_refused(pair, tmp_path, names, words):
    """On main a COG was written as m.jpg and a GeoPackage as s.shp (exit 0): files that what their names
    promise (a JPEG viewer, a Shapefile reader) read wrongly or not at all."""
    seams = ["--seamlines", str(tmp_path / names[1])] if names[1] else []
    result = CliRunner().invoke(main, ["mosaic", str(pair[0]), str(pair[1]), "-o", str(tmp_path / names[0]), *seams])
    assert_one_line_error(result, words)
    assert not list(tmp_path.iterdir())


def test_another_band_set_names_the_gdal_fix(pair, tmp_path):
    """An RGBA neighbour of an RGB orthophoto (here: two bands against one) was refused with 'mosaic
    orthophotos of one kind' on main, which says no way out."""
    with rasterio.open(pair[1]) as ds:
        img, prof = ds.read(), ds.profile
    prof.update(count=2)
    with rasterio.open(tmp_path / "two.tif", "w", **prof) as ds:
        ds.write(np.concatenate([img, np.full_like(img, 255)]))
    result = CliRunner().invoke(main, ["mosaic", str(pair[0]), str(tmp_path / "two.tif"), "-o", str(tmp_path / "m.tif")])
    assert_one_line_error(result, "has 2 bands of uint8")
    assert "gdal_translate -b to keep the same bands, -ot to convert" in result.stderr


def _plain(path, x0, y0, values):
    """A 1-band uint8 orthophoto without nodata, mask or alpha, its top-left corner ``(x0, y0)`` m from the origin."""
    h, w = values.shape
    with rasterio.open(path, "w", driver="GTiff", width=w, height=h, count=1, dtype="uint8", crs="EPSG:32635",
                       transform=Affine(1.0, 0, X0 + x0, 0, -1.0, Y1 - y0)) as ds:
        ds.write(values, 1)
    return str(path)


@pytest.mark.parametrize("full, tile", [(False, None), (True, None), (True, 64)])
def test_a_real_zero_is_kept_and_the_nodata_is_a_value_the_data_lack(tmp_path, monkeypatch, full, tile):
    """Orthophotos without nodata whose data hold 0: the mosaic keeps every value (its nodata of 0 wrote them as 1);
    its nodata is a value no data pixel holds (here 255), or, when the data use all 256 values, none — the valid
    area is then an internal mask band — also when assembled from tiles."""
    import fotogeo.tools.ortho.mosaic_tiles as mt
    if tile:
        monkeypatch.setattr(mt, "TILE", tile)
    c, r = np.meshgrid(np.arange(160) + 0.5, np.arange(120) + 0.5)
    a = np.clip(np.rint(texture(c, r)), 0, 255).astype(np.uint8)
    a[10:30, 5:40] = 0  # a black patch (shadow, water) far from the seam
    if full:
        a[100:104, 0:64] = np.arange(256, dtype=np.uint8).reshape(4, 64)  # every grey level
    b = np.clip(np.rint(texture(c + 100, r + 40)), 0, 255).astype(np.uint8)
    paths = [_plain(tmp_path / "a.tif", 0, 0, a), _plain(tmp_path / "b.tif", 100, 40, b)]
    rep = mosaic(paths, str(tmp_path / "m.tif"), balance=False)
    with rasterio.open(tmp_path / "m.tif") as ds:
        m, mask, nodata, flags = ds.read(1), ds.read_masks(1), ds.nodata, ds.mask_flag_enums
        assert ds.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
    assert m.shape == (160, 260)
    assert np.array_equal(m[10:30, 5:40], np.zeros((20, 35), np.uint8))  # the zeros kept ...
    assert (mask[10:30, 5:40] == 255).all()  # ... and valid
    assert np.array_equal(m[:120, :80], a[:, :80])  # away from the seam: a's values, every one
    assert (mask[:40, 160:] == 0).all() and (mask[120:, :100] == 0).all()  # the corners no image covers
    assert (mask[:120, :160] == 255).all() and (mask[40:, 100:] == 255).all()
    if full:
        assert nodata is None and flags == ([rasterio.enums.MaskFlags.per_dataset],) and rep["nodata"] is None
        assert "mask band" in rep["valid_area"]
    else:
        assert nodata == 255 and rep["nodata"] == 255 and rep["valid_area"] == "a value no data pixel holds"
    assert rep["moved_off_nodata"] == 0


def test_a_blend_landing_on_the_shared_nodata_is_moved_off_it():
    from fotogeo.tools.ortho.mosaic_nodata import shared_nodata
    from fotogeo.tools.ortho.mosaic_tiles import off_nodata
    assert shared_nodata([0, 0]) == 0 and shared_nodata([0, None]) is None and shared_nodata([0, 255]) is None
    assert np.isnan(shared_nodata([float("nan"), float("nan")]))
    out = np.array([[[255, 3], [255, 255]]], np.uint8)
    valid = np.array([[True, True], [False, True]])
    assert off_nodata(out, valid, 255) == 2 and out.tolist() == [[[254, 3], [255, 254]]]
