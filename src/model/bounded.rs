//! Fixed-capacity containers that remember an overflow while decoding.
//!
//! `heapless` containers refuse a sequence longer than their capacity with a serde error, and
//! postcard folds every serde error into one opaque kind. These wrappers instead keep the first
//! `N` elements, read and drop the rest, and remember that they overflowed, so validation can
//! report [`Error::InvalidCapacity`](crate::Error::InvalidCapacity) with the field's name.

use core::fmt;
use core::marker::PhantomData;
use core::ops::Deref;

use serde::de::{SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A vector of at most `N` elements (see the module docs).
#[derive(Clone, PartialEq)]
pub struct BoundedVec<T, const N: usize> {
    items: heapless::Vec<T, N>,
    overflowed: bool,
}

impl<T, const N: usize> BoundedVec<T, N> {
    /// An empty vector.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            items: heapless::Vec::new(),
            overflowed: false,
        }
    }

    /// A vector holding a copy of `items`, or `None` when there are more than `N`.
    #[must_use]
    pub fn from_slice(items: &[T]) -> Option<Self>
    where
        T: Clone,
    {
        Some(Self {
            items: heapless::Vec::from_slice(items).ok()?,
            overflowed: false,
        })
    }

    /// Appends an element, or hands it back when the vector is full.
    ///
    /// # Errors
    /// The element itself, when the vector already holds `N` elements.
    pub fn push(&mut self, item: T) -> Result<(), T> {
        self.items.push(item)
    }

    /// Removes every element and the overflow mark.
    pub fn clear(&mut self) {
        self.items.clear();
        self.overflowed = false;
    }

    /// Appends an element, or drops it and marks the vector as overflowed when it is full (how
    /// a decoder records a sequence longer than the capacity).
    pub(crate) fn push_or_mark(&mut self, item: T) {
        if self.items.push(item).is_err() {
            self.overflowed = true;
        }
    }

    /// The elements as a slice.
    #[must_use]
    pub fn as_slice(&self) -> &[T] {
        &self.items
    }

    /// The elements as a mutable slice.
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        &mut self.items
    }

    /// True when a decoded sequence had more than `N` elements (the extra ones were dropped).
    #[must_use]
    pub const fn overflowed(&self) -> bool {
        self.overflowed
    }

    /// The capacity `N`.
    #[must_use]
    pub const fn capacity(&self) -> usize {
        N
    }
}

impl<T, const N: usize> Default for BoundedVec<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T, const N: usize> Deref for BoundedVec<T, N> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.items
    }
}

impl<T: fmt::Debug, const N: usize> fmt::Debug for BoundedVec<T, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.items.iter()).finish()
    }
}

impl<T: Serialize, const N: usize> Serialize for BoundedVec<T, N> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(self.items.iter())
    }
}

impl<'de, T: Deserialize<'de>, const N: usize> Deserialize<'de> for BoundedVec<T, N> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct BoundedVisitor<T, const N: usize>(PhantomData<T>);

        impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for BoundedVisitor<T, N> {
            type Value = BoundedVec<T, N>;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "a sequence")
            }

            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut out = BoundedVec::new();
                while let Some(item) = seq.next_element::<T>()? {
                    out.push_or_mark(item);
                }
                Ok(out)
            }
        }

        deserializer.deserialize_seq(BoundedVisitor::<T, N>(PhantomData))
    }
}

#[cfg(feature = "defmt")]
impl<T: defmt::Format, const N: usize> defmt::Format for BoundedVec<T, N> {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "{=[?]}", self.as_slice());
    }
}

/// A unit serial number: up to [`SERIAL_CAPACITY`](super::SERIAL_CAPACITY) bytes of printable
/// ASCII.
#[derive(Clone, PartialEq, Eq, Default)]
pub struct Serial {
    text: heapless::String<{ super::SERIAL_CAPACITY }>,
    overflowed: bool,
}

impl Serial {
    /// The empty serial (not valid in a calibration).
    pub const EMPTY: Self = Self {
        text: heapless::String::new(),
        overflowed: false,
    };

    /// A serial number from text, or `None` when it is longer than the capacity.
    #[must_use]
    pub fn new(text: &str) -> Option<Self> {
        let mut s = heapless::String::new();
        s.push_str(text).ok()?;
        Some(Self {
            text: s,
            overflowed: false,
        })
    }

    /// The serial number as text.
    #[must_use]
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// The one rule for a serial a calibration may carry: 1 to
    /// [`SERIAL_CAPACITY`](super::SERIAL_CAPACITY) printable ASCII characters (spaces allowed),
    /// not cut when it was decoded.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        !self.overflowed
            && !self.text.is_empty()
            && self.text.bytes().all(|b| b.is_ascii_graphic() || b == b' ')
    }

    /// A serial from text that obeys [the rule](Self::is_valid), or `None`.
    #[must_use]
    pub fn parse(text: &str) -> Option<Self> {
        Self::new(text).filter(Self::is_valid)
    }

    /// True when a decoded serial was longer than the capacity (it was cut).
    #[must_use]
    pub const fn overflowed(&self) -> bool {
        self.overflowed
    }
}

impl fmt::Debug for Serial {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self.as_str(), f)
    }
}

impl fmt::Display for Serial {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Serial {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "{=str}", self.as_str());
    }
}

impl Serialize for Serial {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for Serial {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct SerialVisitor;

        impl Visitor<'_> for SerialVisitor {
            type Value = Serial;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "a serial number")
            }

            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Serial, E> {
                let mut out = Serial::default();
                for ch in v.chars() {
                    if out.text.push(ch).is_err() {
                        out.overflowed = true;
                        break;
                    }
                }
                Ok(out)
            }
        }

        deserializer.deserialize_str(SerialVisitor)
    }
}
