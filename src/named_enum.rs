//! `named_enum!`: an enumeration whose variants each have a name, declared once with it.

/// Declares an enum as written (attributes, documentation, discriminants), each variant
/// followed by `=> "its name"`, and adds `ALL`, every variant in the order declared,
/// `from_value()`, the variant of a number, and `name()`, the variant's name (the enum's documentation says where the names are used):
///
/// ```ignore
/// named_enum! {
///     pub enum Side {
///         /// The convex side.
///         Outside = 1 => "outside",
///         Inside = 2 => "inside",
///     }
/// }
/// ```
macro_rules! named_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $enum:ident {
            $($(#[$variant_meta:meta])* $variant:ident $(= $value:expr)? => $name:literal,)+
        }
    ) => {
        $(#[$meta])*
        $vis enum $enum {
            $($(#[$variant_meta])* $variant $(= $value)?,)+
        }

        impl $enum {
            /// Every variant, in the order declared.
            pub const ALL: [$enum; [$(stringify!($variant)),+].len()] = [$($enum::$variant),+];

            /// The variant whose number is `value` (none: no such variant).
            pub fn from_value(value: i64) -> Option<$enum> {
                $enum::ALL.into_iter().find(|v| *v as i64 == value)
            }

            /// The variant's name.
            pub fn name(self) -> &'static str {
                match self {
                    $($enum::$variant => $name,)+
                }
            }
        }
    };
}
