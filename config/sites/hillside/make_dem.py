"""Write the example site's DEM: a SYNTHETIC hillside, 1 m pixels, in UTM zone 32N (EPSG:32632).

Not a survey of a real place. A plateau at about 111 m drops over a face of about 35 deg, then 42 deg below a break,
to a valley floor at 100 m; the face curves across the map (its toe moves 4 m over 70 m) and the
plateau has a gentle rise and ripple, so the hillshade reads as terrain. matplotlib's sample data
ship a real DEM (jacksboro_fault_dem.npz), but at 3 arc-seconds (75 x 92 m pixels) it cannot
resolve a slope tens of metres long. Run from the repository root:

    python config/sites/hillside/make_dem.py
"""

from pathlib import Path

import numpy as np
import rasterio
from rasterio.transform import Affine

ORIGIN = (500_000.0, 5_100_070.0)  # west and north edges of the raster (m)
WIDTH, HEIGHT, PIXEL = 120, 70, 1.0


def ground(easting: np.ndarray, northing: np.ndarray) -> np.ndarray:
    """Ground elevation (m) of the synthetic hillside."""
    u = easting - ORIGIN[0]
    v = northing - (ORIGIN[1] - HEIGHT * PIXEL)
    shift = 4.0 * np.sin(2.0 * np.pi * v / 70.0)
    crest, brink, toe = 30.0 + shift, 38.0 + shift, 44.0 + shift  # brink: the break in the face
    plateau = 111.0 + 0.04 * (crest - u) + 0.3 * np.sin(2.0 * np.pi * v / 23.0)
    face = np.where(
        u <= brink,
        plateau - (plateau - 105.5) * (u - crest) / (brink - crest),
        105.5 - 5.5 * (u - brink) / (toe - brink),
    )
    floor = 100.0 - 0.02 * np.clip(u - toe, 0.0, None)
    return np.where(u <= crest, plateau, np.where(u <= toe, face, floor))


DEM = Path(__file__).with_name("dem.tif")


def main(path: Path = DEM) -> None:
    easting = ORIGIN[0] + PIXEL * (np.arange(WIDTH) + 0.5)
    northing = ORIGIN[1] - PIXEL * (np.arange(HEIGHT) + 0.5)
    elevation = ground(*np.meshgrid(easting, northing)).astype("float32")
    profile = {
        "driver": "GTiff",
        "width": WIDTH,
        "height": HEIGHT,
        "count": 1,
        "dtype": "float32",
        "crs": "EPSG:32632",
        "transform": Affine(PIXEL, 0.0, ORIGIN[0], 0.0, -PIXEL, ORIGIN[1]),
        "nodata": -9999.0,
        "compress": "deflate",
    }
    with rasterio.open(path, "w", **profile) as dataset:
        dataset.write(elevation, 1)
    print(f"{path}: {WIDTH} x {HEIGHT} pixels of {PIXEL} m, elevation {elevation.min():.1f} to {elevation.max():.1f} m")


if __name__ == "__main__":
    main()
