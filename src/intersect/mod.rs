//! Mesh-mesh intersections (being written).
