//! Scene generators (placeholder, replaced by the generator work).
