"""Finding the markers in an image: cv2.aruco's detector with sub-pixel corner refinement, and the detections
drawn over the image for the live view."""

from __future__ import annotations

import cv2
import numpy as np

from robot_controller.core.vision.markers import ARUCO_DICTIONARY


class MarkerDetector:
    def __init__(self, dictionary: str = ARUCO_DICTIONARY):
        parameters = cv2.aruco.DetectorParameters()
        # Corners to a tenth of a pixel (the default is the contour's whole pixels): the joint estimate's precision.
        parameters.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
        self._detector = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, dictionary)))
        self._detector.setDetectorParameters(parameters)

    def detect(self, image: np.ndarray) -> dict[int, np.ndarray]:
        """Marker id -> its corners (4, 2) px, float64, in cv2.aruco's order (the marker image's top-left,
        top-right, bottom-right, bottom-left). An id seen twice is dropped: which one is which is unknown."""
        gray = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY) if image.ndim == 3 else image
        corners, ids, _rejected = self._detector.detectMarkers(gray)
        if ids is None:
            return {}
        found: dict[int, np.ndarray] = {}
        repeated = set()
        for marker_id, points in zip(ids.reshape(-1).tolist(), corners, strict=True):
            if marker_id in found:
                repeated.add(marker_id)
            found[marker_id] = np.asarray(points, dtype=np.float64).reshape(4, 2)
        return {k: v for k, v in found.items() if k not in repeated}

    @staticmethod
    def draw(image: np.ndarray, detections: dict[int, np.ndarray]) -> np.ndarray:
        """A copy of ``image`` with each detection outlined and its id written."""
        drawn = np.ascontiguousarray(image).copy()
        if drawn.ndim == 2:
            drawn = cv2.cvtColor(drawn, cv2.COLOR_GRAY2RGB)
        if detections:
            ids = np.array(list(detections), dtype=np.int32).reshape(-1, 1)
            corners = [c.reshape(1, 4, 2).astype(np.float32) for c in detections.values()]
            cv2.aruco.drawDetectedMarkers(drawn, corners, ids, borderColor=(0, 255, 0))
        return drawn
