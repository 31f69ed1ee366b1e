"""Numbers fixed by Jung, Aloni, Yitzhaky & Peli (2015).

The paper: "Active confocal imaging for visual prostheses".

Every constant cites the section it comes from (house style H9).
"""

from __future__ import annotations

__all__ = [
    "WORKING_SHAPE_PX",
    "WINDOWS_PX",
    "RESOLUTIONS_PX",
    "PIXEL_COUNTS",
    "EDGE_RATIO",
    "GREY_LEVELS",
    "CAMERA_FOCAL_LENGTH_MM",
    "CAMERA_HFOV_DEG",
    "NARROW_F_NUMBER",
    "WIDE_F_NUMBER",
    "OBJECT_DISTANCE_M",
    "LF_SIM_PLANES_M",
    "LF_SIM_LENS_PITCH_MM",
    "LF_SIM_LENS_FOCAL_MM",
    "LF_SIM_RELAY_MINIFICATION",
    "LF_SIM_PIXELS_PER_LENS",
    "HAAR_EDGE_FRACTION",
    "SCREEN_SHAPE_PX",
    "VIEWING_DISTANCE_CM",
    "IMAGE_SIZE_CM",
    "SCREEN_WIDTH_CM",
    "BORDER_RGB",
]

#: Working size (rows, cols) of the edge images. Source: Sec. 3.1 ("492x327").
WORKING_SHAPE_PX: tuple[int, int] = (327, 492)

#: Compression windows in pixels, 1 = uncompressed.
#: Source: Sec. 3.1 (windows 2, 3, 5, 7, 13, 18, 40).
WINDOWS_PX: tuple[int, ...] = (1, 2, 3, 5, 7, 13, 18, 40)

#: Stimulus resolutions (rows, cols) for each window, level 8 (full) first as in the paper's list.
#: Source: Sec. 3.1: 492x327, 246x164, 164x109, 98x65, 70x47, 38x25, 27x18, 12x8.
RESOLUTIONS_PX: tuple[tuple[int, int], ...] = (
    (327, 492),
    (164, 246),
    (109, 164),
    (65, 98),
    (47, 70),
    (25, 38),
    (18, 27),
    (8, 12),
)

#: Pixel counts of the eight levels. Source: Sec. 3.1 (160,884 ... 96 pixels).
PIXEL_COUNTS: tuple[int, ...] = (160_884, 40_344, 17_876, 6_370, 3_290, 950, 486, 96)

#: Edge ratio: the mean edge-pixel fraction of the wide-DOF edge images (1/13). Source: Sec. 2.2.
EDGE_RATIO: float = 1.0 / 13.0

#: Grey-level compression levels shown in Fig. 2.
GREY_LEVELS: tuple[int, ...] = (8, 4, 2)

#: Camera of the photo study (Sony NEX-3N, 50 mm lens). Source: Sec. 3.1.
CAMERA_FOCAL_LENGTH_MM: float = 50.0
#: Horizontal field of view of the photos, degrees. Source: Sec. 3.1 ("25 deg horizontal field").
CAMERA_HFOV_DEG: float = 25.0
#: Aperture of the narrow depth-of-field ("confocal") photos. Source: Sec. 3.1.
NARROW_F_NUMBER: float = 1.7
#: Aperture of the wide depth-of-field ("conventional") photos. Source: Sec. 3.1.
WIDE_F_NUMBER: float = 22.0
#: Camera-to-object distance, metres. Source: Sec. 3.1 ("~80 cm").
OBJECT_DISTANCE_M: float = 0.8

#: Depths of the three planes of the simulated light field (pedestrian, tree, building), metres.
#: Source: Sec. 4.1, Fig. 10.
LF_SIM_PLANES_M: tuple[float, float, float] = (1.0, 4.0, 9.0)
#: Lens-array pitch, mm. Source: Sec. 4.1.
LF_SIM_LENS_PITCH_MM: float = 1.0
#: Lens-array focal length, mm. Source: Sec. 4.1.
LF_SIM_LENS_FOCAL_MM: float = 3.0
#: Relay-optics minification of the scene. Source: Sec. 4.1 ("minified 40x").
LF_SIM_RELAY_MINIFICATION: float = 40.0
#: Pixels per lenslet (per axis). Source: Sec. 4.1 ("10x10 pixels per lenslet").
LF_SIM_PIXELS_PER_LENS: int = 10

#: Fraction of each Haar detail sub-band kept as edges in depth-plane detection. Source: Sec. 4.2.
HAAR_EDGE_FRACTION: float = 0.005

#: Subject's screen (rows, cols), px. Source: Sec. 3.1 (21" CRT, 1280x1024).
SCREEN_SHAPE_PX: tuple[int, int] = (1024, 1280)
#: Viewing distance, cm. Source: Sec. 3.1 ("80 cm").
VIEWING_DISTANCE_CM: float = 80.0
#: Displayed image size (height, width), cm. Source: Sec. 3.1 ("14.6 x 9.7 cm", i.e.
#: 10.4 x 6.9 deg at 80 cm).
IMAGE_SIZE_CM: tuple[float, float] = (9.7, 14.6)
#: Visible width of the CRT, cm. Ours, not the paper's: the paper gives no width; this value makes
#: its 492 x 327 px working image exactly 14.6 x 9.7 cm (492 px / 14.6 cm = 33.7 px/cm, and
#: 1280 px / 33.7 px/cm = 37.98 cm), which is what a 21" CRT's visible width is.
SCREEN_WIDTH_CM: float = 1280 * 14.6 / 492
#: Border colour around the image, device RGB 0-255. Source: Sec. 3.1 ("blue").
BORDER_RGB: tuple[int, int, int] = (0, 0, 255)
