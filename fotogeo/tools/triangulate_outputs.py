"""What ``fotogeo triangulate`` writes: the GeoPackage layers and the report of a bundle adjustment."""
from __future__ import annotations

import numpy as np


def _points3d(xyz):
    import shapely
    return shapely.points(np.asarray(xyz, dtype=np.float64))


def block_layers(result, block) -> dict:
    """``tie_points``, ``control``, ``frames`` and ``residuals`` layers (module docstring of
    :mod:`fotogeo.tools.triangulate`)."""
    ids = np.array(block.point_ids, dtype=object)
    live = np.isfinite(result.point_xyz).all(axis=1)
    tie = live & (result.roles == "tie")
    known = live & (result.roles != "tie")
    d = result.point_xyz[known] - block.point_xyz[known]
    eo = np.array([[e.X, e.Y, e.Z, e.omega, e.phi, e.kappa] for e in result.eo])
    o_live = live[block.obs_point]
    n_used = np.bincount(block.obs_frame[result.status == "used"], minlength=len(block.frames))
    return {
        "tie_points": {"geometry": _points3d(result.point_xyz[tie]), "id": ids[tie].astype(str),
                       "rays": result.point_rays[tie], "sigma_x": result.point_sigma[tie, 0],
                       "sigma_y": result.point_sigma[tie, 1], "sigma_z": result.point_sigma[tie, 2]},
        "control": {"geometry": _points3d(result.point_xyz[known]), "id": ids[known].astype(str),
                    "role": result.roles[known], "rays": result.point_rays[known], "dx": d[:, 0], "dy": d[:, 1],
                    "dz": d[:, 2], "given_x": block.point_xyz[known, 0], "given_y": block.point_xyz[known, 1],
                    "given_z": block.point_xyz[known, 2]},
        "frames": {"geometry": _points3d(eo[:, :3]), "name": np.array(block.frames, dtype=str),
                   "omega": eo[:, 3], "phi": eo[:, 4], "kappa": eo[:, 5], "sigma_x0": result.eo_sigma[:, 0],
                   "sigma_y0": result.eo_sigma[:, 1], "sigma_z0": result.eo_sigma[:, 2],
                   "observations": n_used},
        "residuals": {"geometry": _points3d(result.point_xyz[block.obs_point[o_live]]),
                      "frame": np.array(block.frames, dtype=object)[block.obs_frame[o_live]].astype(str),
                      "point": ids[block.obs_point[o_live]].astype(str),
                      "col": block.obs_pixel[o_live, 0], "row": block.obs_pixel[o_live, 1],
                      "dx_px": result.residuals[o_live, 0], "dy_px": result.residuals[o_live, 1],
                      "status": result.status[o_live], "w": result.w_test[o_live]},
    }


def report(result, block, crs, inputs: dict) -> dict:
    """The JSON report of one adjustment."""
    cam = result.camera
    return {"fotogeo": "triangulate", **inputs, "crs": crs.to_string(),
            "units": "ground: metres in crs; image: pixels (corner convention); residual = projected − measured",
            "sigma0": result.sigma0, "statistics": result.stats,
            "camera": {"focal_length": cam.focal_length, "principal_point": list(cam.principal_point),
                       **result.distortion, "sigma": result.interior_sigma},
            "fixed_parameters": list(result.fixed), "correlations": list(result.correlations),
            "blunders": list(result.blunders),
            "frames": [{"name": n, "X": e.X, "Y": e.Y, "Z": e.Z, "omega": e.omega, "phi": e.phi, "kappa": e.kappa,
                        "sigma": dict(zip(("X0", "Y0", "Z0", "rx_deg", "ry_deg", "rz_deg"), map(float, s)))}
                       for n, e, s in zip(block.frames, result.eo, result.eo_sigma)],
            "iterations": result.iterations, "timings_s": result.timings}
