//! [`crate::named_enum!`]: an enum of named choices (profile models, render methods, light types) and
//! its list, names and parser, generated from one list so that they cannot drift apart. The
//! Python package reads the lists through `_core` (argparse choices, TOML keys, checks).

/// `named_enum!(#[doc] pub enum T ("what") { #[doc] Variant = "name", … })` defines the enum
/// (`Clone, Copy, Debug, PartialEq, Eq, Hash`) with `T::ALL` (every variant, in declaration
/// order), `T::NAMES`, `t.name()` and `T::from_name(field, name)`, whose error names `field` and
/// lists the names (`method = "x" is not a render method: must be one of [...]`).
#[macro_export]
macro_rules! named_enum {
    ($(#[$meta:meta])* $vis:vis enum $T:ident ($what:literal) {
        $($(#[$vmeta:meta])* $V:ident = $name:literal),+ $(,)?
    }) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        $vis enum $T {
            $($(#[$vmeta])* $V),+
        }

        impl $T {
            /// Every variant, in declaration order.
            pub const ALL: &'static [$T] = &[$($T::$V),+];
            /// Every name, in the order of [`Self::ALL`].
            pub const NAMES: &'static [&'static str] = &[$($name),+];

            /// The variant's name.
            pub fn name(self) -> &'static str {
                match self {
                    $($T::$V => $name),+
                }
            }

            /// The variant called `name`; anything else is an error naming `field` and listing
            /// the names.
            pub fn from_name(field: &str, name: &str) -> $crate::Result<$T> {
                Self::ALL.iter().copied().find(|v| v.name() == name).ok_or_else(|| {
                    $crate::Error::Invalid(format!(
                        "{field} = {name:?} is not {}: must be one of {:?}",
                        $what,
                        Self::NAMES
                    ))
                })
            }
        }
    };
}

#[cfg(test)]
mod tests {
    crate::named_enum! {
        /// Test choices.
        enum Colour ("a colour") { Red = "red", Green = "green" }
    }

    #[test]
    fn names_round_trip_and_errors_list_them() {
        assert_eq!(Colour::ALL, &[Colour::Red, Colour::Green]);
        for &c in Colour::ALL {
            assert_eq!(Colour::from_name("c", c.name()).unwrap(), c);
        }
        let e = Colour::from_name("paint", "blue").unwrap_err().to_string();
        assert_eq!(e, r#"paint = "blue" is not a colour: must be one of ["red", "green"]"#);
    }
}
