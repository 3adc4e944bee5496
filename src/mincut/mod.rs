//! Min-cut (being written).
