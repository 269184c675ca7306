//! Analytic form factors (placeholder, replaced by the analytic-module work).
