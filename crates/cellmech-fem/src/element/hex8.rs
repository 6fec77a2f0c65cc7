//! 8-node hexahedron, total Lagrangian. TODO(helper: hex8+material): implement.
