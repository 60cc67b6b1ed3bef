//! Dihedral bending angle (placeholder: being written).
