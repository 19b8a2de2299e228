"""Camera geometry: lens models, cameras in the world, virtual views, triangulation."""
