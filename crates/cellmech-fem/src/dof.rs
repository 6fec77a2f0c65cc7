//! Degrees of freedom: which global DOF belongs to which node component.
