//! Checked settings: a settings type as a spec reads it is unchecked (public fields, serde
//! defaults); [`Check::check`] validates it, with errors naming the field, and gives a
//! [`Checked`] value. A `Checked` value reads like the settings it holds but has no mutable
//! access, so it cannot be changed into an invalid one: to change a field, take the settings
//! out ([`Checked::into_inner`]), change them and check them again. Code that computes takes
//! `&Checked<…>`, so every tunable it reads has passed its check.
use crate::error::{Result, SmidError};
use serde::Serialize;
use std::ops::Deref;

/// Settings that validate themselves.
pub trait Check: Sized {
    /// Where the settings sit in a spec (`method.member`), for the errors' field names.
    const PLACE: &'static str;

    /// The first invalid field and what was expected: `(field, message)`, the field relative
    /// to [`Check::PLACE`].
    fn invalid(&self) -> Option<(&'static str, String)>;

    /// The settings checked, or an error naming the first invalid field (as
    /// `PLACE.field`).
    fn check(self) -> Result<Checked<Self>> {
        match self.invalid() {
            Some((field, message)) => Err(SmidError::invalid(
                format!("{}.{field}", Self::PLACE),
                message,
            )),
            None => Ok(Checked(self)),
        }
    }
}

/// Settings that passed [`Check::check`]; read-only.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(transparent)]
pub struct Checked<T>(T);

impl<T> Checked<T> {
    /// The settings, to change and check again.
    pub fn into_inner(self) -> T {
        self.0
    }
}

impl<T> Deref for Checked<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::MemberSpec;

    /// Every field of the member search's settings is checked: an invalid value of each is
    /// refused by name, the defaults and the light budget pass, and a checked value changes
    /// only through a new check.
    #[test]
    fn invalid_member_settings_are_refused_by_field() {
        assert!(MemberSpec::default().check().is_ok());
        assert!(MemberSpec::LIGHT.check().is_ok());
        let d = MemberSpec::default();
        let cases: Vec<(MemberSpec, &str)> = vec![
            (MemberSpec { probe: 0, ..d }, "method.member.probe"),
            (MemberSpec { cells: 0, ..d }, "method.member.cells"),
            (
                MemberSpec { iterations: 0, ..d },
                "method.member.iterations",
            ),
            (
                MemberSpec {
                    iterations: 100_001,
                    ..d
                },
                "method.member.iterations",
            ),
            (MemberSpec { restarts: 0, ..d }, "method.member.restarts"),
            (MemberSpec { restarts: 101, ..d }, "method.member.restarts"),
            (MemberSpec { far: 0.0, ..d }, "method.member.far"),
            (MemberSpec { far: f64::NAN, ..d }, "method.member.far"),
            (
                MemberSpec {
                    hopeless: -1.0,
                    ..d
                },
                "method.member.hopeless",
            ),
            (
                MemberSpec {
                    hopeless: f64::INFINITY,
                    ..d
                },
                "method.member.hopeless",
            ),
            (
                MemberSpec {
                    hopeless_after: 0,
                    ..d
                },
                "method.member.hopeless_after",
            ),
        ];
        for (m, field) in cases {
            match m.check() {
                Err(SmidError::Invalid { field: f, .. }) => assert_eq!(f, field),
                other => panic!("{field}: {other:?}"),
            }
        }
        let checked = MemberSpec::default().check().unwrap();
        let mut again = checked.into_inner();
        again.restarts = 0;
        assert!(again.check().is_err());
    }
}
