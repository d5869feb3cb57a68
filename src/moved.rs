//! Settings keys that moved to another table: a field of type [`Moved`] in a table's serde
//! struct refuses any value given for an old key, naming its new place, so an old settings
//! file fails at its line with the fix. Used by `[slam]` and `[nav]`; it depends on nothing
//! above serde, so every stage can use it.

/// The keys of a table that moved elsewhere (`KEYS[i]` = (old key, new place)), for
/// [`Moved`].
pub(crate) trait MovedKeys {
    /// The table the old keys were in.
    const TABLE: &'static str;
    /// (old key, its new place), in field order.
    const KEYS: &'static [(&'static str, &'static str)];
    /// Why they moved, said after the new place.
    const WHY: &'static str;
}

/// A key that moved: it deserialises from nothing, and any value given is refused with the
/// key's new place (`K::KEYS[I]`), so an old settings file fails at its line with the fix.
pub(crate) struct Moved<K, const I: usize>(std::marker::PhantomData<K>);

impl<K, const I: usize> Default for Moved<K, I> {
    fn default() -> Self {
        Self(std::marker::PhantomData)
    }
}

impl<'de, K: MovedKeys, const I: usize> serde::Deserialize<'de> for Moved<K, I> {
    fn deserialize<D: serde::Deserializer<'de>>(_: D) -> std::result::Result<Self, D::Error> {
        let (old, new) = K::KEYS[I];
        Err(serde::de::Error::custom(format!(
            "`{}.{old}` moved to `{new}` ({})",
            K::TABLE,
            K::WHY
        )))
    }
}
