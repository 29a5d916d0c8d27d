//! The status of a dual variable in its box, shared by the solver ([`super::smo`]), its
//! working-set selection ([`super::select`]) and screening ([`super::screening`]).

/// Where a dual variable lies in its box. One byte each, with these values, so that the
/// working-set selection's vector code reads them directly (see [`super::select`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub(super) enum Bound {
    Lower = 0,
    Upper = 1,
    Free = 2,
}

impl Bound {
    /// Where `alpha` lies in the box `[0, C]`.
    pub(super) fn of(alpha: f64, c: f64) -> Self {
        if alpha >= c {
            Bound::Upper
        } else if alpha <= 0.0 {
            Bound::Lower
        } else {
            Bound::Free
        }
    }
}
