"""The 3-D browser viewer (viser, extra ``viz``): ``viewer`` (the server, the page, :func:`view` and :func:`play`;
its names are exported here), ``geometry`` (visuals or a skeleton), ``scene`` (camera, seabed, triads), ``gui`` (the
panel), ``collision`` (collision shapes and closest pairs) and ``teach`` (the teach sliders, also in a notebook)."""

from .viewer import (
                     EE_COLOUR,
                     SKELETON_COLOUR,
                     Viewer,
                     ViewerUnavailable,
                     check_port,
                     geometry_models,
                     play,
                     request_refusal,
                     require_viser,
                     skeleton_geometry,
                     view,
)

__all__ = ["EE_COLOUR", "SKELETON_COLOUR", "Viewer", "ViewerUnavailable", "check_port", "geometry_models", "play",
           "request_refusal", "require_viser", "skeleton_geometry", "view"]
