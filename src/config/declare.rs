//! The machinery behind the field table ([`super::fields`]): `config_fields!` takes one row
//! per field and writes everything that follows from it — the storage members of [`Config`],
//! [`TestSetup`] and [`AxisConfig`] with their defaults, the [`Field`] enum, the [`FIELDS`]
//! table, the value accessors, the texts, the encoding version that added each field and when
//! each takes effect. Written as `macro_rules!` (not a derive crate): the table stays plain
//! Rust a newcomer can read, and nothing but the table's output reaches the flash image.
//!
//! A row's columns, in order:
//!
//! ```text
//! Variant[(k)] = owner.member (kind) wire = default;
//!     unit [min, max]|codes needed|optional since V at effect
//!     "meaning",
//! ```
//!
//! - `owner`: `config` (a member of [`Config`]), `setup` (of [`TestSetup`]) or `axes` (of each
//!   [`AxisConfig`] in `Config::axes`: the row has an element per encoder input);
//! - `kind`: `(f32)`, `(f64)`, `(u8)`, `(u16)`, `(u32)` or `(code Enum)` (a `u8` code naming one
//!   of `Enum::NAMES`);
//! - `wire`: the name users see, `"name"` for one value, `["name_x", "name_y", …]` for a
//!   family with one table row (and one CANopen object) per element, `{"name"; N}` for one row
//!   of `N` elements (SCPI and the docs add the element number to the name);
//! - `default`: the value (an array for a family or an `N`-element row, one per element);
//! - `[min, max]`: the allowed range (inclusive; `codes`: 0 … the last code);
//! - `needed` / `optional`: whether the field may be **not set** (NaN);
//! - `since V`: the encoding version that added the field ([`super::encoding`]);
//! - `at effect`: a [`TakesEffect`] variant.
//!
//! [`Config`]: super::Config
//! [`TestSetup`]: super::TestSetup
//! [`AxisConfig`]: super::AxisConfig
//! [`Field`]: super::Field
//! [`FIELDS`]: super::FIELDS
//! [`TakesEffect`]: super::TakesEffect

/// The Rust type a field kind is stored as.
macro_rules! kind_type {
    ((code $e:ident)) => {
        $e
    };
    (($t:ident)) => {
        $t
    };
}

/// The [`super::FieldType`] of a field kind.
macro_rules! kind_storage {
    ((f32)) => {
        FieldType::F32
    };
    ((f64)) => {
        FieldType::F64
    };
    ((u8)) => {
        FieldType::U8
    };
    ((u16)) => {
        FieldType::U16
    };
    ((u32)) => {
        FieldType::U32
    };
    ((code $e:ident)) => {
        FieldType::U8
    };
}

/// A stored value of a field kind as `f64` in its unit.
macro_rules! kind_get {
    ((f64), $v:expr) => {
        $v
    };
    ((code $e:ident), $v:expr) => {
        f64::from($v as u8)
    };
    (($t:ident), $v:expr) => {
        f64::from($v)
    };
}

/// Stores `v` (`f64`, the field's unit) into the place `p` of a field kind: the nearest `f32`,
/// the `f64` as is, the nearest integer (saturating), or a known code (an unknown one keeps the
/// old value and fails validation).
macro_rules! kind_set {
    ((f32), $p:expr, $v:ident) => {
        *$p = $v as f32
    };
    ((f64), $p:expr, $v:ident) => {
        *$p = $v
    };
    ((code $e:ident), $p:expr, $v:ident) => {{
        let int = libm::round($v);
        if let Some(x) = $e::from_u8(int as u8).filter(|_| int >= 0.0) {
            *$p = x;
        }
    }};
    (($t:ident), $p:expr, $v:ident) => {
        *$p = libm::round($v) as $t
    };
}

/// The code names of a field kind (empty for a number).
macro_rules! kind_choices {
    ((code $e:ident)) => {
        &$e::NAMES
    };
    (($t:ident)) => {
        &[]
    };
}

/// The member type of a row: the kind's type, or an array of it for a family or an
/// `N`-element row.
macro_rules! member_type {
    ($kind:tt $w:literal) => { kind_type!($kind) };
    ($kind:tt [$($n:literal),+ $(,)?]) => { [kind_type!($kind); [$($n),+].len()] };
    ($kind:tt {$w:literal; $n:expr}) => { [kind_type!($kind); $n] };
}

/// `true` for a field that may be not set.
macro_rules! may_be_unset {
    (optional) => {
        true
    };
    (needed) => {
        false
    };
}

/// `_` for an element index in a pattern.
macro_rules! any_index {
    ($k:ident) => {
        _
    };
}

/// `u8`: the element index of a family or `N`-element variant.
macro_rules! index_type {
    ($k:ident) => {
        u8
    };
}

/// The table rows of one declaration: one for a single value or an `N`-element row, one per
/// element for a family (named in order, each its own field).
macro_rules! declare_rows {
    (@row $field:expr, $kind:tt, $w:expr, $unit:ident, $range:tt, $n:expr, $need:ident) => {
        FieldInfo {
            field: $field,
            name: $w,
            unit: Unit::$unit,
            ty: kind_storage!($kind),
            min: range_min!($kind, $range),
            max: range_max!($kind, $range),
            elements: $n,
            optional: may_be_unset!($need),
        }
    };
    ($field:expr, $kind:tt, $w:literal, $unit:ident, $range:tt, $need:ident) => {
        [declare_rows!(@row $field, $kind, $w, $unit, $range, 0, $need)]
    };
    ($field:expr, $kind:tt, {$w:literal; $n:expr}, $unit:ident, $range:tt, $need:ident) => {
        [declare_rows!(@row $field, $kind, $w, $unit, $range, $n as u8, $need)]
    };
    ($field:expr, $kind:tt, [$($w:literal),+ $(,)?], $unit:ident, $range:tt, $need:ident) => {
        family(declare_rows!(@row $field, $kind, "", $unit, $range, 0, $need), [$($w),+])
    };
}

/// The table key of a field: element 0 for an `N`-element row's elements (they share its
/// row), the field itself otherwise.
macro_rules! row_key {
    ($var:ident, {$w:literal; $n:expr}, $k:ident) => {
        Field::$var(0)
    };
    ($var:ident, $wire:tt, $k:ident) => {
        Field::$var($k)
    };
    ($var:ident, $wire:tt,) => {
        Field::$var
    };
}

/// The variant with element index `i` (the variant alone when it has no index).
macro_rules! with_index {
    ($var:ident, $i:expr, $k:ident) => {
        Field::$var($i)
    };
    ($var:ident, $i:expr,) => {
        Field::$var
    };
}

/// The smallest value of a row's range (`codes`: 0).
macro_rules! range_min {
    ($kind:tt, [$min:expr, $max:expr]) => {
        $min
    };
    ($kind:tt, codes) => {
        0.0
    };
}

/// The largest value of a row's range (`codes`: the last code).
macro_rules! range_max {
    ($kind:tt, [$min:expr, $max:expr]) => {
        $max
    };
    ($kind:tt, codes) => {
        (kind_choices!($kind).len() as f64 - 1.0)
    };
}

/// A field's value as `f64` (`None` for an element that does not exist).
macro_rules! get_value {
    ($c:ident, config, $m:ident, $kind:tt,) => {
        Some(kind_get!($kind, $c.$m))
    };
    ($c:ident, setup, $m:ident, $kind:tt,) => {
        Some(kind_get!($kind, $c.setup.$m))
    };
    ($c:ident, config, $m:ident, $kind:tt, $k:ident) => {
        $c.$m.get(usize::from($k)).map(|x| kind_get!($kind, *x))
    };
    ($c:ident, setup, $m:ident, $kind:tt, $k:ident) => {
        $c.setup
            .$m
            .get(usize::from($k))
            .map(|x| kind_get!($kind, *x))
    };
    ($c:ident, axes, $m:ident, $kind:tt, $k:ident) => {
        $c.axes.get(usize::from($k)).map(|a| kind_get!($kind, a.$m))
    };
}

/// Stores `v` into a field (nothing for an element that does not exist).
macro_rules! set_value {
    ($c:ident, config, $m:ident, $kind:tt, $v:ident,) => {
        kind_set!($kind, &mut $c.$m, $v)
    };
    ($c:ident, setup, $m:ident, $kind:tt, $v:ident,) => {
        kind_set!($kind, &mut $c.setup.$m, $v)
    };
    ($c:ident, config, $m:ident, $kind:tt, $v:ident, $k:ident) => {
        if let Some(p) = $c.$m.get_mut(usize::from($k)) {
            kind_set!($kind, p, $v)
        }
    };
    ($c:ident, setup, $m:ident, $kind:tt, $v:ident, $k:ident) => {
        if let Some(p) = $c.setup.$m.get_mut(usize::from($k)) {
            kind_set!($kind, p, $v)
        }
    };
    ($c:ident, axes, $m:ident, $kind:tt, $v:ident, $k:ident) => {
        if let Some(a) = $c.axes.get_mut(usize::from($k)) {
            kind_set!($kind, &mut a.$m, $v)
        }
    };
}

/// Sorts the members of the rows into their structs (a recursive macro: one row a step), then
/// writes the three structs and their defaults.
macro_rules! declare_storage {
    (
        @split
        [$($c:tt)*] [$($s:tt)*] [$($a:tt)*] [$($cd:tt)*] [$($sd:tt)*] [$($ad:tt)*]
        ([$($at:tt)*] config $m:ident $kind:tt $wire:tt ($d:expr) $mean:literal)
        $($rest:tt)*
    ) => {
        declare_storage! {
            @split
            [$($c)* $($at)* #[doc = $mean] pub $m: member_type!($kind $wire),]
            [$($s)*] [$($a)*]
            [$($cd)* $($at)* $m: $d,]
            [$($sd)*] [$($ad)*]
            $($rest)*
        }
    };
    (
        @split
        [$($c:tt)*] [$($s:tt)*] [$($a:tt)*] [$($cd:tt)*] [$($sd:tt)*] [$($ad:tt)*]
        ([$($at:tt)*] setup $m:ident $kind:tt $wire:tt ($d:expr) $mean:literal)
        $($rest:tt)*
    ) => {
        declare_storage! {
            @split
            [$($c)*]
            [$($s)* $($at)* #[doc = $mean] pub $m: member_type!($kind $wire),]
            [$($a)*] [$($cd)*]
            [$($sd)* $($at)* $m: $d,]
            [$($ad)*]
            $($rest)*
        }
    };
    (
        @split
        [$($c:tt)*] [$($s:tt)*] [$($a:tt)*] [$($cd:tt)*] [$($sd:tt)*] [$($ad:tt)*]
        ([$($at:tt)*] axes $m:ident $kind:tt $wire:tt ($d:expr) $mean:literal)
        $($rest:tt)*
    ) => {
        declare_storage! {
            @split
            [$($c)*] [$($s)*]
            [$($a)* $($at)* #[doc = $mean] pub $m: kind_type!($kind),]
            [$($cd)*] [$($sd)*]
            [$($ad)* $($at)* $m: ($d)[K],]
            $($rest)*
        }
    };
    (
        @split
        [$($c:tt)*] [$($s:tt)*] [$($a:tt)*] [$($cd:tt)*] [$($sd:tt)*] [$($ad:tt)*]
    ) => {
        /// The test set-up: the geometry and uncertainty budget each measuring pattern needs
        /// (machine coordinates, mm and degrees). A length or position that the pod cannot know
        /// by itself is **not set** (NaN) until a client writes it; arming a pattern whose
        /// geometry is not set is refused with the field named ([`crate::app`]).
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct TestSetup {
            $($s)*
        }

        /// The pod's configuration (see the module doc; fields listed with unit, default and
        /// range in [`FIELDS`](super::FIELDS)).
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Config {
            $($c)*
            /// Encoder inputs 1…[`MAX_AXES`].
            pub axes: [AxisConfig; MAX_AXES],
            /// The test set-up (pattern geometry and budget).
            pub setup: TestSetup,
        }

        /// One encoder input.
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct AxisConfig {
            $($a)*
        }

        impl TestSetup {
            /// The defaults: every length and position not set (NaN), the limits and budgets.
            // a constant, so a default is a copy from flash
            pub const DEFAULT: Self = Self { $($sd)* };
        }

        impl Config {
            /// The defaults (the tables of the book's configuration reference).
            pub const DEFAULT: Self = Self {
                $($cd)*
                axes: [
                    axis_default::<0>(),
                    axis_default::<1>(),
                    axis_default::<2>(),
                    axis_default::<3>(),
                    axis_default::<4>(),
                ],
                setup: TestSetup::DEFAULT,
            };
        }

        /// The defaults of encoder input `K`.
        // compile-time evaluation only: an element beyond a default's length is a build error
        #[allow(clippy::indexing_slicing)]
        const fn axis_default<const K: usize>() -> AxisConfig {
            AxisConfig { $($ad)* }
        }
    };
}

/// The whole declaration (see the module doc for a row's columns).
macro_rules! config_fields {
    (
        config { $($(#[$ca:meta])* $cm:ident: $ct:ty = $cd:expr),* $(,)? }
        axes { $($(#[$aa:meta])* $am:ident: $at:ty = $ad:expr),* $(,)? }
        rules { $($(#[$ra:meta])* $rule:ident $(($rk:ident))? => $rmean:literal),* $(,)? }
        rows {
            $(
                $(#[$attr:meta])*
                $var:ident $(($k:ident))? = $owner:ident . $member:ident $kind:tt $wire:tt = $default:expr;
                $unit:ident $range:tt $need:ident since $since:literal at $effect:ident
                $meaning:literal
            ),* $(,)?
        }
    ) => {
        declare_storage! {
            @split
            [$($(#[$ca])* pub $cm: $ct,)*]
            [] [$($(#[$aa])* pub $am: $at,)*]
            [$($cm: $cd,)*]
            [] [$($am: ($ad)[K],)*]
            $(([$(#[$attr])*] $owner $member $kind $wire ($default) $meaning))*
        }

        /// A configuration field: a value (named in [`ConfigError`](super::ConfigError) and in
        /// [`FIELDS`](super::FIELDS)) or a
        /// rule across fields.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum Field {
            $(
                $(#[$attr])*
                #[doc = $meaning]
                $var $((index_type!($k)))?,
            )*
            $(
                $(#[$ra])*
                #[doc = $rmean]
                $rule $((index_type!($rk)))?,
            )*
        }

        /// The rows of each declaration, in declaration order.
        pub(super) const GROUPS: &[&[FieldInfo]] = &[
            $(
                $(#[$attr])*
                &declare_rows!(with_index!($var, 0, $($k)?), $kind, $wire, $unit, $range, $need),
            )*
        ];

        impl Field {
            /// What the field is, for the EDS and the book's configuration reference (the
            /// firmware never calls it, so the text is not in flash).
            pub const fn meaning(self) -> &'static str {
                match self {
                    $($(#[$attr])* Field::$var $((any_index!($k)))? => $meaning,)*
                    $(Field::$rule $((any_index!($rk)))? => $rmean,)*
                }
            }

            /// The encoding version that added the field (the encoding, `config/encoding.rs`); 0 for a
            /// rule, which is not stored.
            pub const fn since(self) -> u16 {
                match self {
                    $($(#[$attr])* Field::$var $((any_index!($k)))? => $since,)*
                    $(Field::$rule $((any_index!($rk)))? => 0,)*
                }
            }

            /// When a written value takes effect ([`TakesEffect`]).
            pub const fn takes_effect(self) -> TakesEffect {
                match self {
                    $($(#[$attr])* Field::$var $((any_index!($k)))? => TakesEffect::$effect,)*
                    $(Field::$rule $((any_index!($rk)))? => TakesEffect::NextSample,)*
                }
            }

            /// The same field with element index `k` (itself for a field without elements).
            pub const fn at(self, k: u8) -> Field {
                match self {
                    $($(#[$attr])* Field::$var $((any_index!($k)))? => with_index!($var, k, $($k)?),)*
                    $(Field::$rule $((any_index!($rk)))? => with_index!($rule, k, $($rk)?),)*
                }
            }

            /// The table key: element 0 for an element of an `N`-element row, which shares the
            /// row; the field itself otherwise.
            #[allow(unused_variables)]
            pub(super) const fn key(self) -> Field {
                match self {
                    $($(#[$attr])* Field::$var $(($k))? => row_key!($var, $wire, $($k)?),)*
                    f => f,
                }
            }

            /// For a code field: the name of each code, in code order; empty for any other.
            pub const fn choices(self) -> &'static [&'static str] {
                match self {
                    $($(#[$attr])* Field::$var $((any_index!($k)))? => kind_choices!($kind),)*
                    _ => &[],
                }
            }
        }

        impl Config {
            /// A numeric field's value as `f64` in its unit (NaN for a set-up field that is not
            /// set; `None` for a rule or an element that does not exist). The one accessor the
            /// protocol layers (CANopen objects, SCPI `CONFigure`) and the encoding share.
            pub fn field_value(&self, f: Field) -> Option<f64> {
                let c = self;
                match f {
                    $($(#[$attr])* Field::$var $(($k))? => get_value!(c, $owner, $member, $kind, $($k)?),)*
                    $(Field::$rule $((any_index!($rk)))? => None,)*
                }
            }

            /// Sets a numeric field from `v` in its unit: `f32` fields take the nearest `f32`,
            /// integer fields the nearest integer (saturating; a code field an unknown code
            /// keeps the old value and fails validation), `f64` fields `v` as is. No range
            /// check here: use it inside [`Config::try_update`], which validates the result
            /// (the `f32` limits are compared rounded to `f32`, so every value the table allows
            /// can be set).
            pub fn set_field(&mut self, f: Field, v: f64) {
                let c = self;
                match f {
                    $($(#[$attr])* Field::$var $(($k))? => set_value!(c, $owner, $member, $kind, v, $($k)?),)*
                    $(Field::$rule $((any_index!($rk)))? => {})*
                }
            }
        }
    };
}
