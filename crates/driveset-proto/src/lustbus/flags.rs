//! A tiny bit-flag newtype generator for the LUSTBUS bit fields (SIOF/SERR,
//! description attributes and filters), so the crate needs no `bitflags`
//! dependency.

/// Declares a `Copy` newtype over an unsigned integer with named flag
/// constants, each carrying a short label.
macro_rules! bit_flags {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident: $ty:ty {
            $(
                $(#[$fmeta:meta])*
                const $flag:ident = $mask:expr, $label:expr;
            )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
        $vis struct $name(pub $ty);

        #[allow(dead_code)]
        impl $name {
            $(
                $(#[$fmeta])*
                pub const $flag: Self = Self($mask);
            )*

            /// Every flag this type names, in bit order, with its label.
            pub const NAMED: &'static [(Self, &'static str)] = &[$((Self::$flag, $label)),*];

            /// The union of every named flag.
            pub const KNOWN: Self = Self(0 $(| $mask)*);

            /// Wraps raw bits, keeping bits that have no name.
            pub const fn from_bits_retain(bits: $ty) -> Self {
                Self(bits)
            }

            /// The raw bits.
            pub const fn bits(self) -> $ty {
                self.0
            }

            /// No bit set.
            pub const fn is_empty(self) -> bool {
                self.0 == 0
            }

            /// Every bit of `other` is set in `self`.
            pub const fn contains(self, other: Self) -> bool {
                self.0 & other.0 == other.0
            }

            /// At least one bit of `other` is set in `self`.
            pub const fn intersects(self, other: Self) -> bool {
                self.0 & other.0 != 0
            }

            /// The bits set that no named flag covers.
            pub const fn unknown_bits(self) -> $ty {
                self.0 & !Self::KNOWN.0
            }

            /// The labels of the named flags that are set, in bit order.
            pub fn labels(self) -> impl Iterator<Item = &'static str> {
                Self::NAMED
                    .iter()
                    .filter(move |(f, _)| f.0 != 0 && self.contains(*f))
                    .map(|(_, l)| *l)
            }
        }

        impl ::core::ops::BitOr for $name {
            type Output = Self;
            fn bitor(self, rhs: Self) -> Self {
                Self(self.0 | rhs.0)
            }
        }

        impl ::core::ops::BitOrAssign for $name {
            fn bitor_assign(&mut self, rhs: Self) {
                self.0 |= rhs.0;
            }
        }

        impl ::core::fmt::Debug for $name {
            fn fmt(&self, f: &mut ::core::fmt::Formatter<'_>) -> ::core::fmt::Result {
                write!(f, "{}({:#x}", stringify!($name), self.0)?;
                let mut sep = ": ";
                for l in self.labels() {
                    write!(f, "{sep}{l}")?;
                    sep = " | ";
                }
                if self.unknown_bits() != 0 {
                    write!(f, "{sep}unknown {:#x}", self.unknown_bits())?;
                }
                write!(f, ")")
            }
        }
    };
}
