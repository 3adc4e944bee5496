//! (in progress) Rig configuration of the contact pass.
