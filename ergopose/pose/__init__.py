"""2D pose: model management, person finding, upright views, keypoint decoding."""
