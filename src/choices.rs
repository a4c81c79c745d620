//! The closed sets of named choices of the settings and the scene format (integrator, kernel,
//! …): one macro writes each enum with its names for files, the command line and messages.

/// Defines a closed set of named choices: the enum, its serde and clap names (one name per
/// variant), [`std::fmt::Display`], `FromStr` (whose error lists the choices) and `ALL`.
macro_rules! choices {
    (
        $(#[doc = $doc:literal])*
        $vis:vis enum $ty:ident ($what:literal) {
            $( $(#[doc = $vdoc:literal])* $variant:ident = $name:literal, )+
        }
    ) => {
        $(#[doc = $doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
        #[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
        $vis enum $ty {
            $(
                $(#[doc = $vdoc])*
                #[serde(rename = $name)]
                #[cfg_attr(feature = "cli", value(name = $name))]
                $variant,
            )+
        }

        impl $ty {
            /// Every choice.
            pub const ALL: &'static [$ty] = &[$($ty::$variant),+];

            /// Name as written in scene files and on the command line.
            pub fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $name,)+
                }
            }
        }

        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl std::str::FromStr for $ty {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, Self::Err> {
                $(if s == $name {
                    return Ok($ty::$variant);
                })+
                let names = [$($name),+];
                Err(format!("unknown {} `{s}`; expected {}", $what, $crate::choices::one_of(&names)))
            }
        }
    };
}
pub(crate) use choices;

/// `"a"`, `"a" or "b"`, `"a", "b" or "c"`, …
pub(crate) fn one_of(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
    match quoted.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    }
}
