//! In-place construction of the pod's large state.
//!
//! A value returned by a constructor is built in a stack temporary and then moved; for the
//! application (26 KiB), the circular test (12 KiB) or an SSM run (8 KiB) that temporary is
//! most of the firmware's stack (book "Performance and memory", §Stack). Each large type has one
//! `init(slot: &mut MaybeUninit<Self>, …) -> &mut Self` written with [`init_in_place!`], which
//! writes the fields one by one straight into their final place (a `static` on the pod); its
//! `new` is [`build`] of that `init` and its restart [`reinit`], so the field list is written
//! once. Hand-written: the crates that do this (`pin-init`) need a proc-macro and an allocator.

use core::mem::MaybeUninit;

/// Writes every field of struct `$T` into `$slot` (a `&mut MaybeUninit<$T>`) in place and
/// evaluates to the initialised `&mut $T`. Fields after `in place` are themselves built in
/// place by an initialiser (`FnOnce(&mut MaybeUninit<F>) -> &mut F`, an `init` of this crate).
/// The field list is checked complete by the compiler: a struct literal of the same fields,
/// never built, fails to compile if one is missing, repeated or unknown.
macro_rules! init_in_place {
    ($slot:expr, $T:ident { $($field:ident : $value:expr),* $(,)? }
        $(in place { $($nested:ident : $init:expr),+ $(,)? })?) => {{
        let slot: &mut core::mem::MaybeUninit<$T> = $slot;
        #[allow(unreachable_code, clippy::empty_loop)]
        let _every_field_once = || $T { $($field: loop {},)* $($($nested: loop {},)+)? };
        let p = slot.as_mut_ptr();
        $(
            let value = $value;
            // SAFETY: `p` comes from a `&mut MaybeUninit<$T>`, so the field is valid for writes
            // and aligned.
            unsafe { (&raw mut (*p).$field).write(value) };
        )*
        $($(
            // SAFETY: as above; the field is borrowed by nothing else while it is initialised.
            let field = unsafe { crate::in_place::uninit(&raw mut (*p).$nested) };
            let _ = ($init)(field);
        )+)?
        // SAFETY: every field was written above (an initialiser initialises the slot it is
        // given), and `_every_field_once` proves the list is all of them.
        unsafe { slot.assume_init_mut() }
    }};
}

pub(crate) use init_in_place;

/// The place `p` of a `T` as a `MaybeUninit<T>` (the cast keeps the field's own type).
///
/// # Safety
/// `p` is valid for writes and aligned, and nothing else borrows it for `'a`.
pub(crate) unsafe fn uninit<'a, T>(p: *mut T) -> &'a mut MaybeUninit<T> {
    // SAFETY: `MaybeUninit<T>` has the layout of `T`; the rest is the caller's.
    unsafe { &mut *p.cast::<MaybeUninit<T>>() }
}

/// A value built by `init` and returned by value (for the host and the tests; on the pod a
/// large state is built in its `static`). `init` is an `init` of this crate: an
/// [`init_in_place!`], or a function that ends in one on the slot it is given.
pub(crate) fn build<T>(init: impl FnOnce(&mut MaybeUninit<T>) -> &mut T) -> T {
    let mut slot = MaybeUninit::uninit();
    let _ = init(&mut slot);
    // SAFETY: `init` initialised the slot (above).
    unsafe { slot.assume_init() }
}

/// Rebuilds `value` in place with `init` (restarting a large state without a stack copy).
pub(crate) fn reinit<T: Copy>(value: &mut T, init: impl FnOnce(&mut MaybeUninit<T>) -> &mut T) {
    // SAFETY: `value` is valid for writes, aligned and borrowed by nothing else. `init` writes
    // whole fields only (`init_in_place!`), so the place holds a valid `T` throughout, and a
    // `T: Copy` has no drop to skip.
    let slot = unsafe { uninit(value) };
    let _ = init(slot);
}

/// Fills the array in `slot` with `value`, element by element in place.
pub(crate) fn fill<T: Copy, const N: usize>(
    slot: &mut MaybeUninit<[T; N]>,
    value: T,
) -> &mut [T; N] {
    let p = slot.as_mut_ptr().cast::<T>();
    for i in 0..N {
        // SAFETY: element `i < N` of the array behind `p`: valid for writes and aligned.
        unsafe { p.add(i).write(value) };
    }
    // SAFETY: all N elements were written.
    unsafe { slot.assume_init_mut() }
}
