//! Radiance views.

/// Projection types.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ViewType {
    Perspective,
}

/// A view.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    pub vtype: ViewType,
}
