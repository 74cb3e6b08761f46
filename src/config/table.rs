//! The field table's row type ([`FieldInfo`]), the table itself ([`FIELDS`], flattened from
//! the declarations of [`super::fields`]), lookup by field and by name, and the range check
//! of one value.

use super::fields::GROUPS;
use super::{ConfigError, Field, TakesEffect};
use crate::units::Unit;

/// How a field is stored (and sent: CANopen data type, encoding width).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldType {
    /// IEEE 754 single (REAL32).
    F32,
    /// IEEE 754 double (the encoder scales: sent as REAL32 over CANopen, 15 digits over SCPI).
    F64,
    /// Unsigned 8-bit integer (UNSIGNED8); with [`FieldInfo::choices`], a code.
    U8,
    /// Unsigned 16-bit integer (UNSIGNED16).
    U16,
    /// Unsigned 32-bit integer (UNSIGNED32).
    U32,
}

/// Name, unit, type, range and default of a field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldInfo {
    /// The field (for an indexed field, element 0; see [`FieldInfo::elements`]).
    pub field: Field,
    /// Its name as users see it (SCPI / CANopen / docs).
    pub name: &'static str,
    /// Its unit.
    pub unit: Unit,
    /// Storage type.
    pub ty: FieldType,
    /// Smallest allowed value (inclusive).
    pub min: f64,
    /// Largest allowed value (inclusive).
    pub max: f64,
    /// Number of elements of an indexed field (e.g. 4 polynomial coefficients), 0 for a scalar.
    pub elements: u8,
    /// True if the field may be **not set** (NaN; the default of set-up lengths and positions
    /// the pod cannot know). Once written it can only return to "not set" by restoring the
    /// defaults.
    pub optional: bool,
}

impl FieldInfo {
    /// The field of element `k` of this row (the row's own field for a scalar).
    pub const fn element(&self, k: u8) -> Field {
        if self.elements > 0 {
            self.field.at(k)
        } else {
            self.field
        }
    }

    /// Every field of this row: its elements, or the row's field alone.
    pub fn fields(&'static self) -> impl Iterator<Item = Field> {
        let n = self.elements.max(1);
        (0..n).map(move |k| self.element(k))
    }

    /// True for integer storage (U8, U16, U32).
    pub const fn is_integer(&self) -> bool {
        matches!(self.ty, FieldType::U8 | FieldType::U16 | FieldType::U32)
    }

    /// For a code field ([`FieldType::U8`] with named codes): the name of each code, in code
    /// order; empty for any other field (a match on the field, not a slice in every row).
    pub const fn choices(&self) -> &'static [&'static str] {
        self.field.choices()
    }

    /// The code of choice `name` (case-insensitive) of a code field.
    pub fn choice(&self, name: &[u8]) -> Option<u8> {
        self.choices()
            .iter()
            .position(|c| c.as_bytes().eq_ignore_ascii_case(name))
            .map(|i| i as u8)
    }
}

/// The rows of a family (one per element, each its own field, named in order) from the row of
/// element 0 and the names.
// compile-time evaluation only: an index out of bounds is a build error
#[allow(clippy::indexing_slicing)]
pub(super) const fn family<const N: usize>(
    first: FieldInfo,
    names: [&'static str; N],
) -> [FieldInfo; N] {
    let mut out = [first; N];
    let mut k = 0;
    while k < N {
        out[k].field = first.field.at(k as u8);
        out[k].name = names[k];
        k += 1;
    }
    out
}

/// Rows of all declarations.
// compile-time evaluation only: an index out of bounds is a build error
#[allow(clippy::indexing_slicing)]
const fn row_count() -> usize {
    let mut n = 0;
    let mut g = 0;
    while g < GROUPS.len() {
        n += GROUPS[g].len();
        g += 1;
    }
    n
}

/// The declarations' rows in one array.
// compile-time evaluation only: an index out of bounds is a build error
#[allow(clippy::indexing_slicing)]
const fn flatten<const N: usize>() -> [FieldInfo; N] {
    let empty = FieldInfo {
        field: Field::PeriodsPerSample,
        name: "",
        unit: Unit::One,
        ty: FieldType::F32,
        min: 0.0,
        max: 0.0,
        elements: 0,
        optional: false,
    };
    let mut out = [empty; N];
    let (mut n, mut g) = (0, 0);
    while g < GROUPS.len() {
        let mut k = 0;
        while k < GROUPS[g].len() {
            out[n] = GROUPS[g][k];
            n += 1;
            k += 1;
        }
        g += 1;
    }
    out
}

/// Every numeric configuration field with unit, type and range, in wire order: the single
/// table that validation, the binary encoding, the CANopen objects
/// ([`crate::protocol::canopen::od::config_index`] of the row), SCPI `CONFigure`, the EDS and
/// the documentation share (declared in `config/fields.rs`).
pub const FIELDS: &[FieldInfo] = &flatten::<{ row_count() }>();

/// The first `N` fields (by row, each element) that take effect at `when`.
// compile-time evaluation only: an index out of bounds is a build error
#[allow(clippy::indexing_slicing)]
pub(super) const fn fields_taking_effect<const N: usize>(when: TakesEffect) -> [Field; N] {
    let mut out = [Field::PeriodsPerSample; N];
    let (mut n, mut r) = (0, 0);
    while r < FIELDS.len() {
        let f = FIELDS[r].field;
        if f.takes_effect() as u8 == when as u8 {
            out[n] = f;
            n += 1;
        }
        r += 1;
    }
    assert!(n == N, "the count of fields taking effect at `when` is N");
    out
}

/// The table row of a field (the elements of an `N`-element row share the row of element 0).
pub(super) fn info(field: Field) -> Option<&'static FieldInfo> {
    let key = field.key();
    FIELDS.iter().find(|i| i.field == key)
}

/// The field called `name` (as in [`FIELDS`]; `lvdt_poly`, `axis_counts` and `axis_max_speed`
/// take the element as a suffix: `lvdt_poly2`, `axis_counts1`…), or `None`.
pub(super) fn by_name(name: &str) -> Option<Field> {
    if let Some(i) = FIELDS.iter().find(|i| i.elements == 0 && i.name == name) {
        return Some(i.field);
    }
    FIELDS.iter().filter(|i| i.elements > 0).find_map(|i| {
        let k: u8 = name.strip_prefix(i.name)?.parse().ok()?;
        (k < i.elements).then(|| i.element(k))
    })
}

/// Checks one value of `field` against its table row: in range, finite (NaN only where the
/// field may be not set). An `f32` field compares the value it would store (rounded to `f32`)
/// with its limits rounded to `f32`, so a limit such as 0.01, which has no exact binary value,
/// can itself be written whichever way it is given (0.01 as REAL32 over CANopen, or the
/// decimal 0.01 over SCPI).
pub(super) fn check(field: Field, value: f64) -> Result<(), ConfigError> {
    let Some(i) = info(field) else {
        return Ok(());
    };
    let (min, max, stored) = if i.ty == FieldType::F32 {
        let r = |v: f64| f64::from(v as f32);
        (r(i.min), r(i.max), r(value))
    } else {
        (i.min, i.max, value)
    };
    if (value.is_nan() && i.optional) || (stored.is_finite() && stored >= min && stored <= max) {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            field,
            value,
            min: i.min,
            max: i.max,
        })
    }
}

/// True if `v` is a set value (a set-up field that is not set reads NaN).
pub fn is_set(v: f32) -> bool {
    !v.is_nan()
}

/// The value of set-up field `f` that a computation needs (`v`, as f64), or `f` when it is
/// not set.
// one copy in flash for the many set-up fields the application reads
#[inline(never)]
pub fn required(v: f32, f: Field) -> Result<f64, Field> {
    if is_set(v) { Ok(f64::from(v)) } else { Err(f) }
}

/// The X, Y, Z components of set-up field `f` (e.g. [`Field::S002OriginMm`]), all needed.
pub fn required3(v: [f32; 3], f: fn(u8) -> Field) -> Result<[f64; 3], Field> {
    let [x, y, z] = v;
    Ok([required(x, f(0))?, required(y, f(1))?, required(z, f(2))?])
}
