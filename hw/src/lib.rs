//! The shelling machine hardware crate (filled by later issues).
