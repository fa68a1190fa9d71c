"""A rendering ArUco camera: render a neighbour's marker, detect it, solve its pose.

The published sensor model (:mod:`swazure_ros.core.sensor`) is a fitted curve; this module
simulates the measurement the curve was fitted to. A :class:`Camera` is a
pinhole camera with a thin lens (focal length, f-number, focus range) on a
pixel sensor; it looks at an ArUco marker of a given side and renders what the
sensor records: the marker seen through the lens (defocus below the closest
focus, a residual optical blur), photon and read noise, 8-bit quantisation.
:func:`measure` then runs the measurement of the real camera on that frame:
``cv2.aruco.ArucoDetector``, ``cv2.cornerSubPix`` and ``cv2.solvePnPGeneric``
with ``SOLVEPNP_IPPE_SQUARE``.

Units: lengths of the scene in mm, of the image in px, angles in degrees at
the interface. Only the marker's neighbourhood of the image is rendered and
searched (a region of interest); the detector's size limits are converted so
that they mean the same pixels as in the whole frame.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from ..core.arrays import FloatArray

#: Wavelength used for the diffraction blur, mm (green, where the Bayer sensor has most pixels).
WAVELENGTH_MM = 550e-6
#: White margin around the marker beyond the widest window of the measurement
#: (adaptive threshold, corner refinement), px: the marker was on a sheet of
#: paper, so nothing of the measurement may see past the card.
QUIET_ZONE_PX = 12.0


@dataclass(frozen=True)
class Degradations:
    """What makes the recorded frame differ from the ideal projection (camera-independent)."""

    #: Blur left at best focus beyond diffraction (aberrations, demosaicing), px sigma.
    residual_blur_px: float = 0.6
    #: Read noise of a pixel, 8-bit grey levels (sigma).
    read_noise: float = 2.0
    #: Photon noise: variance per grey level of signal (grey levels).
    shot_noise_gain: float = 0.25
    #: Grey level of the printed white and of the printed black, 8-bit.
    white_level: float = 200.0
    black_level: float = 40.0
    #: Grey level of what lies behind the marker's paper.
    background_level: float = 110.0
    #: Half side of the cornerSubPix search window, px (the measurement's own setting).
    corner_window_px: int = 5
    #: Exponent of the camera's transfer curve: light adds up (warp, blur) in linear
    #: intensity, and the frame holds ``level = 255 (I / 255) ** (1 / tone_gamma)``.
    #: 1: linear. The grey levels above are those of the frame.
    tone_gamma: float = 1.0


@dataclass(frozen=True)
class Camera:
    """A pinhole camera with a thin lens reading a square ArUco marker."""

    name: str
    width: int  # px
    height: int  # px
    fx: float  # px
    fy: float  # px
    cx: float  # px
    cy: float  # px
    focal_length_mm: float
    f_number: float
    focus_min_mm: float  # closest distance the lens brings into focus
    marker_dictionary: str = "DICT_4X4_100"
    marker_side_mm: float = 4.7
    marker_id: int = 0
    degradations: Degradations = field(default_factory=Degradations)

    @property
    def matrix(self) -> FloatArray:
        """The 3x3 intrinsic matrix K, px."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def pixel_pitch_mm(self) -> float:
        """Size of one image pixel on the sensor, mm: focal length over fx (binning included)."""
        return self.focal_length_mm / self.fx

    @property
    def aperture_mm(self) -> float:
        """Diameter of the entrance pupil, mm."""
        return self.focal_length_mm / self.f_number

    def defocus_px(self, distance_mm: float, focus_mm: float) -> float:
        """Diameter of the thin lens's blur circle, px, for a point at ``distance_mm``
        when the lens is focused at ``focus_mm`` (``inf`` for infinity)."""
        f = self.focal_length_mm
        if distance_mm <= f:
            return math.inf
        # c = A f |1/d - 1/s| / (1 - f/s) on the sensor (thin lens), in pixels of f / fx.
        inverse_focus = 0.0 if math.isinf(focus_mm) else 1.0 / focus_mm
        blur_mm = (
            self.aperture_mm
            * f
            * abs(1.0 / distance_mm - inverse_focus)
            / (1.0 - f * inverse_focus)
        )
        return blur_mm / self.pixel_pitch_mm

    def focus_for(self, distance_mm: float, rng: np.random.Generator) -> float:
        """Where the autofocus leaves the lens for a marker at ``distance_mm``, mm.

        In its range the autofocus focuses on the marker. Nearer than the
        closest focus it finds no sharp image anywhere in its travel and the
        lens stops at a random place in it: uniform in dioptres between the
        closest focus and infinity (why the blind range begins so close to
        the closest focus, where a lens parked at the near stop would still
        see a marker sharply enough).
        """
        if distance_mm >= self.focus_min_mm:
            return distance_mm
        inverse = rng.uniform(0.0, 1.0 / self.focus_min_mm)
        return math.inf if inverse == 0.0 else 1.0 / inverse

    @property
    def dictionary_size(self) -> int:
        """How many markers the camera's ArUco dictionary holds."""
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.marker_dictionary))
        return int(dictionary.bytesList.shape[0])

    def measure_pairs(
        self,
        distances_mm: FloatArray,
        seed: int,
        first: NDArray[np.int64],
        second: NDArray[np.int64],
        markers: Sequence[int] = (),
    ) -> FloatArray:
        """Marker centres (M, 3) mm of pairs seen head-on, by :func:`measure_pairs`."""
        return measure_pairs(self, distances_mm, seed, first, second, markers=markers)

    def diffraction_px(self) -> float:
        """Sigma of a Gaussian close to the Airy disk of the lens, px."""
        return 0.42 * WAVELENGTH_MM * self.f_number / self.pixel_pitch_mm


# ----------------------------------------------------------------------------- rendering


@dataclass(frozen=True)
class MarkerPose:
    """Where the marker is: its centre in the camera frame and how it is turned."""

    distance_mm: float  # along the optical axis to the marker's centre
    tilt_deg: float = 0.0  # rotation of the marker about the image's vertical axis
    roll_deg: float = 0.0  # rotation of the marker about its own normal
    offset_px: tuple[float, float] = (0.0, 0.0)  # where its centre projects, from (cx, cy)


@dataclass(frozen=True)
class Frame:
    """A rendered region of interest and where it lies in the full image."""

    image: NDArray[np.uint8]  # (h, w) grey
    origin: tuple[int, int]  # (x, y) of the region's top-left pixel in the full image
    corners: FloatArray  # (4, 2) true marker corners in full-image px


def _rotation(tilt_deg: float, roll_deg: float) -> FloatArray:
    """Marker-to-camera rotation: marker facing the camera, tilted then rolled, (3, 3)."""
    tilt, roll = math.radians(tilt_deg), math.radians(roll_deg)
    # A marker facing the camera has its normal (+z) pointing back along -z of the camera.
    face = np.diag([1.0, -1.0, -1.0])
    tilt_y = np.array(
        [[math.cos(tilt), 0, math.sin(tilt)], [0, 1, 0], [-math.sin(tilt), 0, math.cos(tilt)]]
    )
    roll_z = np.array(
        [[math.cos(roll), -math.sin(roll), 0], [math.sin(roll), math.cos(roll), 0], [0, 0, 1]]
    )
    return np.asarray(tilt_y @ face @ roll_z)


def marker_object_points(side_mm: float) -> FloatArray:
    """Corners of a marker of side ``side_mm`` in its own frame, ArUco order, (4, 3) mm."""
    half = side_mm / 2.0
    return np.array([[-half, half, 0], [half, half, 0], [half, -half, 0], [-half, -half, 0]])


def _marker_texture(camera: Camera, texels_per_cell: int, quiet: int) -> NDArray[np.float32]:
    """The printed card: marker bits and ``quiet`` texels of white around, as grey levels."""
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, camera.marker_dictionary))
    cells = dictionary.markerSize + 2
    bits = cv2.aruco.generateImageMarker(
        dictionary, camera.marker_id, cells * texels_per_cell, borderBits=1
    )
    card = cv2.copyMakeBorder(bits, quiet, quiet, quiet, quiet, cv2.BORDER_CONSTANT, value=255)
    d = camera.degradations
    return (d.black_level + (d.white_level - d.black_level) * (card / 255.0)).astype(np.float32)


@functools.lru_cache(maxsize=64)
def _linear_card(camera: Camera, texels_per_cell: int, quiet: int) -> NDArray[np.float32]:
    """The card of :func:`_marker_texture` as linear intensity, read-only.

    Cached: a sweep renders the same few cards frame after frame.
    """
    card = _to_linear(
        _marker_texture(camera, texels_per_cell, quiet), camera.degradations.tone_gamma
    )
    card.flags.writeable = False
    return np.asarray(card, np.float32)


def _to_linear(levels: Any, gamma: float) -> Any:
    """Frame grey levels (0-255) as linear intensity on the same scale."""
    if gamma == 1.0:
        return levels
    return np.float32(255.0) * (np.asarray(levels, np.float32) / np.float32(255.0)) ** gamma


def _from_linear(intensity: NDArray[np.float32], gamma: float) -> NDArray[np.float32]:
    """Linear intensity (0-255 scale) as frame grey levels, through the transfer curve."""
    if gamma == 1.0:
        return intensity
    scaled = np.maximum(intensity, 0.0) / np.float32(255.0)
    return np.asarray(np.float32(255.0) * scaled ** np.float32(1.0 / gamma), np.float32)


def _psf(camera: Camera, distance_mm: float, focus_mm: float) -> NDArray[np.float32]:
    """Point spread function at ``distance_mm``: blur circle convolved with a Gaussian."""
    sigma = math.hypot(camera.diffraction_px(), camera.degradations.residual_blur_px)
    diameter = camera.defocus_px(distance_mm, focus_mm)
    radius = diameter / 2.0
    half = math.ceil(radius + 3.0 * sigma) + 1
    grid = np.arange(-half, half + 1, dtype=np.float64)
    # The blur circle, anti-aliased by 4x4 supersampling of each kernel pixel.
    sub = (np.arange(4) + 0.5) / 4.0 - 0.5
    xs = (grid[:, None] + sub[None, :]).ravel()
    inside = (xs[:, None] ** 2 + xs[None, :] ** 2) <= max(radius, 0.5) ** 2
    disk = inside.reshape(grid.size, 4, grid.size, 4).mean(axis=(1, 3))
    gauss = np.exp(-0.5 * (grid / max(sigma, 1e-6)) ** 2)
    kernel = cv2.sepFilter2D(disk, -1, gauss, gauss, borderType=cv2.BORDER_CONSTANT)
    return np.asarray(kernel / kernel.sum(), dtype=np.float32)


def render(camera: Camera, pose: MarkerPose, rng: np.random.Generator) -> Frame:
    """Render the region of the image around the marker at ``pose``, seeded by ``rng``."""
    rotation = _rotation(pose.tilt_deg, pose.roll_deg)
    centre = true_centre(camera, pose)
    cells = (
        cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, camera.marker_dictionary)).markerSize
        + 2
    )
    corners_3d = marker_object_points(camera.marker_side_mm) @ rotation.T + centre
    corners_px = _project(camera, corners_3d)
    # Texels of about half a pixel: bilinear sampling then keeps edges to a fraction of a pixel.
    edges = np.linalg.norm(np.roll(corners_px, -1, axis=0) - corners_px, axis=1)
    texels_per_cell = max(2, math.ceil(2.0 * float(edges.max()) / cells))
    cell_px = max(float(edges.min()) / cells, 1e-3)
    white_px = max(1.5 * cell_px, camera.degradations.corner_window_px + QUIET_ZONE_PX)
    quiet = math.ceil(white_px / cell_px * texels_per_cell)
    marker_texels = cells * texels_per_cell
    card_side = camera.marker_side_mm * (marker_texels + 2 * quiet) / marker_texels
    card = marker_object_points(card_side) @ rotation.T + centre
    card_px = _project(camera, card)
    psf = _psf(camera, pose.distance_mm, camera.focus_for(pose.distance_mm, rng))
    margin = psf.shape[0] // 2 + 8
    x0 = max(math.floor(card_px[:, 0].min()) - margin, 0)
    y0 = max(math.floor(card_px[:, 1].min()) - margin, 0)
    x1 = min(math.ceil(card_px[:, 0].max()) + margin, camera.width)
    y1 = min(math.ceil(card_px[:, 1].max()) + margin, camera.height)
    if x1 - x0 < 8 or y1 - y0 < 8:
        return Frame(np.zeros((0, 0), np.uint8), (x0, y0), corners_px)
    card_texture = _linear_card(camera, texels_per_cell, quiet)
    n = card_texture.shape[0]
    source = np.array([[0, 0], [n, 0], [n, n], [0, n]], dtype=np.float32) - 0.5
    target = (card_px - np.array([x0, y0])).astype(np.float32)
    homography = cv2.getPerspectiveTransform(source, target)
    d = camera.degradations
    gamma = d.tone_gamma
    scene = cv2.warpPerspective(
        card_texture,
        homography,
        (x1 - x0, y1 - y0),
        flags=cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=float(_to_linear(np.float32(d.background_level), gamma)),
    )
    blurred = np.asarray(cv2.filter2D(scene, -1, psf, borderType=cv2.BORDER_REPLICATE), np.float32)
    scene = _from_linear(blurred, gamma)
    sigma = np.sqrt(d.read_noise**2 + d.shot_noise_gain * np.maximum(scene, 0.0))
    scene = scene + sigma * rng.standard_normal(scene.shape).astype(np.float32)
    image = np.clip(np.rint(scene), 0, 255).astype(np.uint8)
    return Frame(image, (x0, y0), corners_px)


def _project(camera: Camera, points: FloatArray) -> FloatArray:
    """Pinhole projection of camera-frame points (N, 3) mm to pixels (N, 2)."""
    return np.column_stack(
        [
            camera.fx * points[:, 0] / points[:, 2] + camera.cx,
            camera.fy * points[:, 1] / points[:, 2] + camera.cy,
        ]
    )


# ----------------------------------------------------------------------------- measuring


class Detector:
    """The real camera's measurement: ArucoDetector, cornerSubPix, solvePnPGeneric IPPE_SQUARE."""

    def __init__(self, camera: Camera) -> None:
        self.camera = camera
        self._dictionary = cv2.aruco.getPredefinedDictionary(
            getattr(cv2.aruco, camera.marker_dictionary)
        )
        self._default = cv2.aruco.DetectorParameters()
        self._objects = marker_object_points(camera.marker_side_mm).astype(np.float32)
        window = camera.degradations.corner_window_px
        self._window = (window, window)
        self._criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 30, 0.01)

    def _detector_for(self, shape: tuple[int, int]) -> cv2.aruco.ArucoDetector:
        """A detector whose perimeter limits mean the same pixels in a region as in the frame."""
        parameters = cv2.aruco.DetectorParameters()
        scale = max(self.camera.width, self.camera.height) / max(shape)
        parameters.minMarkerPerimeterRate = self._default.minMarkerPerimeterRate * scale
        # The upper limit stays: a marker cannot outgrow its region, and OpenCV
        # rejects every candidate when that rate is very large.
        return cv2.aruco.ArucoDetector(self._dictionary, parameters)

    def markers(
        self, image: NDArray[np.uint8], only: int | None = None
    ) -> list[tuple[int, FloatArray]]:
        """Every marker of the dictionary in grey ``image`` (h, w): (id, refined corners (4, 2)).

        In the order OpenCV finds them; with ``only``, the first marker of
        that id alone. Corners are refined each on its own (cornerSubPix), so
        a marker's corners do not depend on what else the image shows.
        """
        if image.size == 0:
            return []
        found, ids, _ = self._detector_for(image.shape).detectMarkers(image)
        if ids is None:
            return []
        read = [(int(i), c) for c, i in zip(found, ids.ravel(), strict=True)]
        if only is not None:
            read = [(i, c) for i, c in read if i == only][:1]
        return [
            (
                marker,
                np.asarray(
                    cv2.cornerSubPix(
                        image,
                        corners.reshape(4, 1, 2).astype(np.float32),
                        self._window,
                        (-1, -1),
                        self._criteria,
                    ),
                    np.float64,
                ).reshape(4, 2),
            )
            for marker, corners in read
        ]

    def corners(self, frame: Frame) -> FloatArray | None:
        """Refined corners (4, 2) full-image px of the camera's marker in ``frame``, or None."""
        read = self.markers(frame.image, only=self.camera.marker_id)
        if not read:
            return None
        return read[0][1] + np.array(frame.origin, np.float64)

    def solve(self, corners: FloatArray) -> FloatArray | None:
        """Marker centre (3,) mm in the camera frame from its corners; None if no pose fits.

        IPPE_SQUARE returns two poses, sorted by reprojection error; they differ
        in the marker's tilt and hardly in its position. The rule: the pose with
        the smaller reprojection error, and on a tie within 5 % the one whose
        marker faces the camera more directly (the geometry of the swarm: every
        marker is mounted facing out of its FLS).
        """
        count, rotations, translations, errors = cv2.solvePnPGeneric(
            self._objects,
            corners.astype(np.float32).reshape(4, 1, 2),
            self.camera.matrix,
            None,
            flags=cv2.SOLVEPNP_IPPE_SQUARE,
        )
        if count == 0:
            # Refined corners that no square fits (they collapsed onto one another).
            return None
        if not np.all(np.isfinite(translations)):
            return None  # no pose fits either: never a non-finite centre
        best = 0
        if count > 1:
            errors = np.asarray(errors).ravel()
            tied = errors[1] <= errors[0] * 1.05 + 1e-9
            if tied:
                facing = [-cv2.Rodrigues(rotation)[0][2, 2] for rotation in rotations[:2]]
                best = int(np.argmax(facing))
        return np.asarray(translations[best], dtype=np.float64).ravel()


def measure(
    camera: Camera, pose: MarkerPose, rng: np.random.Generator, detector: Detector | None = None
) -> FloatArray | None:
    """Render, detect and solve once: the measured marker centre (3,) mm, or None."""
    detector = detector or Detector(camera)
    corners = detector.corners(render(camera, pose, rng))
    if corners is None:
        return None
    return detector.solve(corners)


def true_centre(camera: Camera, pose: MarkerPose) -> FloatArray:
    """The marker centre (3,) mm in the camera frame at ``pose``."""
    return np.array(
        [
            pose.offset_px[0] * pose.distance_mm / camera.fx,
            pose.offset_px[1] * pose.distance_mm / camera.fy,
            pose.distance_mm,
        ]
    )


def camera_seeing(camera: Camera, markers: Sequence[int], index: int) -> Camera:
    """``camera`` aimed at FLS ``index`` (swarm index), which carries markers[index % len].

    With no ``markers`` every FLS carries the camera file's marker.
    """
    if not markers:
        return camera
    return replace(camera, marker_id=int(markers[index % len(markers)]))


def measure_pairs(
    camera: Camera,
    distances_mm: FloatArray,
    seed: int,
    first: NDArray[np.int64],
    second: NDArray[np.int64],
    attempts: int = 8,
    markers: Sequence[int] = (),
) -> FloatArray:
    """Marker centres (M, 3) mm in each measuring camera's frame, one pair per row.

    The marker faces the camera head-on at ``distances_mm`` (M,). Each pair has
    its own random stream, seeded by (seed, first, second), so a pair's
    measurement is the same in every call; the camera looks up to
    ``attempts`` frames and keeps the first that detects. Rows with no
    detection are NaN. The FLS ``second`` carries ``markers[second % len]``
    (default: the camera file's marker).
    """
    detectors: dict[int, Detector] = {}
    centres = np.full((len(distances_mm), 3), np.nan)
    for row, (distance, one, other) in enumerate(zip(distances_mm, first, second, strict=True)):
        seen = camera_seeing(camera, markers, int(other))
        if seen.marker_id not in detectors:
            detectors[seen.marker_id] = Detector(seen)
        detector = detectors[seen.marker_id]
        rng = np.random.default_rng([seed, int(one), int(other)])
        for _ in range(attempts):
            pose = MarkerPose(
                float(distance),
                roll_deg=float(rng.uniform(0.0, 360.0)),
                offset_px=(float(rng.uniform(-0.5, 0.5)), float(rng.uniform(-0.5, 0.5))),
            )
            centre = measure(seen, pose, rng, detector)
            if centre is not None:
                # The frame's sub-pixel placement is the camera's aim, not the neighbour's place.
                centres[row] = (
                    centre
                    - true_centre(camera, pose)
                    + true_centre(camera, MarkerPose(float(distance)))
                )
                break
    return centres


def full_image(camera: Camera, frame: Frame) -> NDArray[np.uint8]:
    """The whole (height, width) image of ``frame``: its region over the background."""
    image = np.full(
        (camera.height, camera.width), round(camera.degradations.background_level), np.uint8
    )
    if frame.image.size:
        x, y = frame.origin
        rows, columns = frame.image.shape
        image[y : y + rows, x : x + columns] = frame.image
    return image
