"""``fotogeo dsm`` refusals name the actual cause: a DEM whose heights do not fit the orientation (in feet read as
metres, another datum) rather than the small overlap its wrong heights make of the footprints."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio

from fotogeo.errors import InputError

from dsm_scenes import make_scene, write_dem


def _scaled_dem(src, dst, scale=1.0, shift=0.0) -> Path:
    with rasterio.open(src) as ds:
        prof, z = ds.profile, ds.read()
    with rasterio.open(dst, "w", **prof) as ds:
        ds.write((z * scale + shift).astype(z.dtype))
    return Path(dst)


def test_a_dem_off_the_orientations_heights_is_named(tmp_path):
    """The nadir block's DEM 400 m too high: refused naming the DEM, both height ranges and the offset (no feet)."""
    from fotogeo.tools.dsm import dsm
    sc = make_scene("nadir", tmp_path / "scene")
    imgs = [p for p in sc["images"] if Path(p).stem in ("s1_01", "s1_02")]
    dem = _scaled_dem(write_dem(sc, tmp_path / "dem.tif"), tmp_path / "high.tif", shift=400.0)
    with pytest.raises(InputError, match=r"DEM '.*high.tif' \(dem\) does not fit the orientation: at \d+ sparse "
                                         r"matches of 's1_01' and 's1_02' it gives heights .* \+400 m apart; check"):
        dsm(imgs, tmp_path / "a.tif", camera=sc["camera"], eo=sc["eo"], dem=dem)
    assert not (tmp_path / "a.tif").exists()


@pytest.mark.data
def test_ngi_dem_in_feet_is_named_as_such(data_dir, tmp_path):
    """NGI's DEM times 3.28084 with its metre tag (sweep case n15) was refused as "overlap 17 %"."""
    from fotogeo.tools.dsm import dsm
    ngi = data_dir / "ngi"
    frames = [ngi / "frames" / f"3324c_2015_1004_05_{n}_RGB.tif" for n in ("0182", "0184")]
    dem = _scaled_dem(ngi / "dem.tif", tmp_path / "dem_ft.tif", scale=3.28084)
    with pytest.raises(InputError, match=r"dem_ft.tif' \(dem\) does not fit the orientation.*3\.\d\d times theirs: "
                                         r"are the DEM's heights in feet\? .*A\*0.3048"):
        dsm(frames, tmp_path / "a.tif", camera=ngi / "interior_orientation.yaml",
            eo=ngi / "exterior_orientation.txt", dem=dem)


@pytest.mark.data
@pytest.mark.parametrize("source", [".geom", "_RPC.TXT", ".RPB", "tags"])
def test_an_rpc_cutout_that_lost_its_place_is_named(data_dir, tmp_path, monkeypatch, source):
    """Ventoux's left image cut at (60, 40) and written without its geotransform beside the product's .geom (sweep
    case v05): its pixels are read at the product's corner, km away; the refusal said only "overlap 0 %". The same
    with the product's RPC in an _RPC.TXT or .RPB beside it, or in its GeoTIFF tags (GDAL's RPC metadata: the check
    skipped them, and the refusal said only "overlap 0 %" again)."""
    import shutil
    import warnings

    from fotogeo.io.rpc import read_rpc, write_rpc_geotiff
    from fotogeo.tools.dsm import dsm
    monkeypatch.setenv("GDAL_PAM_ENABLED", "NO")
    v = data_dir / "rpc" / "ventoux"
    with rasterio.open(v / "left_image.tif") as ds:
        crop = ds.read(window=((40, 440), (60, 460)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # NotGeoreferencedWarning: the point of the case
        with rasterio.open(tmp_path / "left.tif", "w", driver="GTiff", width=400, height=400, count=crop.shape[0],
                           dtype=crop.dtype) as ds:
            ds.write(crop)
    product = read_rpc(v / "left_image.geom")
    if source == ".geom":
        shutil.copy(v / "left_image.geom", tmp_path / "left.geom")
    elif source == "tags":
        write_rpc_geotiff(tmp_path / "left.tif", tmp_path / "tagged.tif", product)
        (tmp_path / "tagged.tif").replace(tmp_path / "left.tif")
    else:
        _rpc_file(product, tmp_path / f"left{source}")
    shutil.copy(v / "right_image.tif", tmp_path / "right.tif")
    shutil.copy(v / "right_image.geom", tmp_path / "right.geom")
    what = "its GeoTIFF RPC tags describe" if source == "tags" else rf"its RPC file '.*left{source}' describes"
    fix = "the RPC of its own pixels" if source == "tags" else "gdal_edit.py -a_ullr"
    with pytest.raises(InputError, match=rf"overlap 0 % below 20 %; 'left' is 400 x 400 pixels without a geotransform"
                                         rf", so its pixel \(0, 0\) is read as the first pixel of the product {what}"
                                         rf".*'right' carries its place in that product \(its pixel \(0, 0\) at "
                                         rf"\(4915, 5162\)\).*{fix}"):
        dsm([tmp_path / "left.tif", tmp_path / "right.tif"], tmp_path / "a.tif", rpc=True)


def _rpc_file(rpc, path):
    """``rpc`` as GDAL's text RPC beside an image: ``_RPC.TXT`` (one coefficient a line) or ``.RPB``."""
    md = rpc.to_gdal_metadata()
    if path.name.endswith(".RPB"):
        names = {"LINE_OFF": "lineOffset", "SAMP_OFF": "sampOffset", "LAT_OFF": "latOffset", "LONG_OFF": "longOffset",
                 "HEIGHT_OFF": "heightOffset", "LINE_SCALE": "lineScale", "SAMP_SCALE": "sampScale",
                 "LAT_SCALE": "latScale", "LONG_SCALE": "longScale", "HEIGHT_SCALE": "heightScale"}
        lines = ['satId = "X";', "BEGIN_GROUP = IMAGE", "\terrBias = 1.0;", "\terrRand = 1.0;"]
        lines += [f"\t{v} = {md[k]};" for k, v in names.items()]
        for k, v in (("LINE_NUM_COEFF", "lineNumCoef"), ("LINE_DEN_COEFF", "lineDenCoef"),
                     ("SAMP_NUM_COEFF", "sampNumCoef"), ("SAMP_DEN_COEFF", "sampDenCoef")):
            lines.append(f"\t{v} = (" + ",".join(md[k].split()) + ");")
        path.write_text("\n".join(lines + ["END_GROUP = IMAGE", "END;"]) + "\n")
        return
    lines = [f"{k}: {v}" for k, v in md.items() if not k.endswith("COEFF")]
    for k in ("LINE_NUM_COEFF", "LINE_DEN_COEFF", "SAMP_NUM_COEFF", "SAMP_DEN_COEFF"):
        lines += [f"{k}_{i + 1}: {v}" for i, v in enumerate(md[k].split())]
    path.write_text("\n".join(lines) + "\n")


def test_noise_bands_are_left_out_of_the_fusion_and_equal_bands_weigh_alike():
    """A band of noise louder than the image was the PCA's first component (ventoux band 1 σ 152 beside noise
    σ 1155: weights -0.0005, 0.35, -0.80, 0.49); it is left out by its neighbour correlation, and three equal
    bands still weigh 1/3 each (the plain mean the DSM matched before)."""
    import warnings

    from fotogeo.errors import FotogeoWarning
    from fotogeo.image.fusion import band_content, band_weights, pca_fuse
    y, x = np.mgrid[0:120, 0:150]
    image = 1000 + 150 * np.sin(x / 7.0) * np.cos(y / 11.0)
    rng = np.random.default_rng(0)
    bands = np.stack([image, rng.uniform(0, 4000, image.shape), rng.uniform(0, 4000, image.shape)])
    assert sorted(band_content(bands)) == [2, 3] and band_content(bands)[2].startswith("noise")
    with pytest.warns(FotogeoWarning, match=r"bands 2 \(noise, neighbour correlation -?0.0\d\), 3 .* fused bands 1"):
        w = band_weights(bands)
    assert w.tolist() == [1.0, 0.0, 0.0]
    with pytest.warns(FotogeoWarning, match="left out of the PCA"):
        assert pca_fuse(bands).bands == (1,)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.allclose(band_weights(np.stack([image] * 3)), 1 / 3)
        assert band_content(rng.normal(size=(3, 40, 50))) == {}  # noise only: nothing to tell the image by


def test_rendered_pair_with_noise_in_bands_2_and_3_matches(tmp_path):
    """The rendered frame pair with bands 2-3 uniform noise (sweep case v13's frame twin): its DSM is as accurate
    as the one-band pair's (matching the mean of the three bands, no height was matched)."""
    from rendered_pair import accuracy, render

    from fotogeo.errors import FotogeoWarning
    from fotogeo.tools.dsm import dsm
    sc = render(tmp_path, 400)
    rng = np.random.default_rng(5)
    noisy = []
    (tmp_path / "noisy").mkdir()
    for p in sc["images"]:
        with rasterio.open(p) as ds:
            prof, a = ds.profile, ds.read(1)
        prof.update(count=3)
        q = tmp_path / "noisy" / Path(p).name
        with rasterio.open(q, "w", **prof) as ds:
            ds.write(np.stack([a] + [rng.integers(0, 256, a.shape).astype(np.uint8) for _ in range(2)]))
        noisy.append(q)
    one = dsm(sc["images"], tmp_path / "one.tif", camera=sc["camera"], eo=sc["eo"], crs="EPSG:32635")
    with pytest.warns(FotogeoWarning, match=r"noisy/r400_a.tif': bands 2 \(noise.*fused bands 1"):
        three = dsm(noisy, tmp_path / "three.tif", camera=sc["camera"], eo=sc["eo"], crs="EPSG:32635")
    a, b = accuracy(tmp_path / "one.tif"), accuracy(tmp_path / "three.tif")
    assert three["completeness"] >= one["completeness"] - 0.01 and b["rmse_m"] <= a["rmse_m"] + 0.005


def test_bands_option_picks_the_bands_matched(tmp_path):
    """``bands`` (``--bands``, QGIS "Bands to match") chooses the bands fused into the grey image; numbers beyond
    the image's bands and bad syntax are refused naming the option."""
    from fotogeo.tools.dsm.inputs import SourceImage
    path = tmp_path / "four.tif"
    y, x = np.mgrid[0:60, 0:80]
    data = np.stack([100 + 50 * np.sin(x / 5.0 + k) * np.cos(y / 7.0) for k in range(4)]).astype(np.uint16)
    with rasterio.open(path, "w", driver="GTiff", width=80, height=60, count=4, dtype="uint16") as ds:
        ds.write(data)
    assert SourceImage(path).bands == [1, 2, 3] and SourceImage(path, "4").bands == [4]
    src = SourceImage(path, "4,2")
    assert src.bands == [4, 2] and np.allclose(np.abs(src.weights).sum(), 1.0)
    with pytest.raises(InputError, match=r"bands 5: image '.*four.tif' has 4 bands \(1-4\)") as e:
        SourceImage(path, 5)
    assert e.value.option == "bands"
    with pytest.raises(InputError, match=r"bands '1,a': give band numbers"):
        SourceImage(path, "1,a")


@pytest.mark.data
@pytest.mark.parametrize("with_dem", [True, False])
def test_ngi_frames_with_their_names_swapped_are_refused_with_or_without_a_dem(data_dir, tmp_path, with_dem):
    """NGI 0182 and 0184 under each other's names (each given the other's EO line): their SIFT matches follow into
    the rectified pair 18 px off the epipolar lines and no two rays meet. With ``--dem`` the pair was matched
    (0 sparse matches read as a textureless pair the DEM guides) into 228 cells 144 m off; now it is refused for
    its orientation, as without a DEM, and neither refusal asks for a DEM."""
    import shutil
    from fotogeo.tools.dsm import dsm
    ngi = data_dir / "ngi"
    for a, b in (("0182", "0184"), ("0184", "0182")):
        shutil.copy(ngi / "frames" / f"3324c_2015_1004_05_{a}_RGB.tif", tmp_path / f"3324c_2015_1004_05_{b}_RGB.tif")
    frames = sorted(tmp_path.glob("*.tif"))
    with rasterio.open(ngi / "dem.tif") as ds:
        crs = ds.crs.to_wkt()
    kw = {"dem": ngi / "dem.tif"} if with_dem else {"crs": crs}
    with pytest.raises(InputError, match=r"the orientation does not fit the images: \d+ sparse matches lie 1\d\.\d px "
                                         r"off their epipolar lines \(their rays do not meet\); check that each image "
                                         r"has its own orientation \(file names swapped\?\)") as e:
        dsm(frames, tmp_path / "a.tif", camera=ngi / "interior_orientation.yaml",
            eo=ngi / "exterior_orientation.txt", **kw)
    assert "--dem" not in str(e.value)
    assert not (tmp_path / "a.tif").exists()
