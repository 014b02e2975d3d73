//! The kinds of sketched and extracted feature — ridges and valleys — as data. A kind
//! indexes arrays ([`PerKind`], one value per kind, serialised as a map from the
//! kinds' names), has a name, a sign (valleys are ridges of the negated field), the
//! kind it turns into upside down, and a pen colour. A new kind is added here and in
//! the cost terms that score it; the stages, the report and the wire format iterate
//! over [`FeatureKind::ALL`].

/// Ridge or valley.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
pub enum FeatureKind {
    Ridge,
    Valley,
}

impl FeatureKind {
    /// Every kind, in index order.
    pub const ALL: [FeatureKind; 2] = [FeatureKind::Ridge, FeatureKind::Valley];
    /// How many kinds there are.
    pub const COUNT: usize = Self::ALL.len();

    /// This kind's place in [`FeatureKind::ALL`] (and in a [`PerKind`]).
    pub fn index(self) -> usize {
        self as usize
    }

    /// The kind at `index`, if there is one.
    pub fn from_index(index: usize) -> Option<FeatureKind> {
        Self::ALL.get(index).copied()
    }

    /// +1 for ridges, -1 for valleys: multiply heights by this to find the kind as ridges.
    pub fn sign(self) -> f32 {
        match self {
            FeatureKind::Ridge => 1.0,
            FeatureKind::Valley => -1.0,
        }
    }

    /// Whether a cross-section's centre height `centre` stands out from a side height
    /// `side` the way this kind does (above it for a ridge, below it for a valley).
    pub fn stands_out(self, centre: f32, side: f32) -> bool {
        match self {
            FeatureKind::Ridge => centre > side,
            FeatureKind::Valley => centre < side,
        }
    }

    /// The kind this one is upside down (heights negated): the fallback when a library
    /// offers no candidate of this kind.
    pub fn inverted(self) -> FeatureKind {
        match self {
            FeatureKind::Ridge => FeatureKind::Valley,
            FeatureKind::Valley => FeatureKind::Ridge,
        }
    }

    /// The kind's name in reports, logs and stroke sketches ("ridge").
    pub fn name(self) -> &'static str {
        match self {
            FeatureKind::Ridge => "ridge",
            FeatureKind::Valley => "valley",
        }
    }

    /// The kind named `name` (as [`FeatureKind::name`] gives it).
    pub fn from_name(name: &str) -> Option<FeatureKind> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The colour a pen of this kind draws in a colour sketch and in the debug views
    /// (red ridges, blue valleys).
    pub fn pen_colour(self) -> [u8; 3] {
        match self {
            FeatureKind::Ridge => [230, 30, 30],
            FeatureKind::Valley => [30, 60, 230],
        }
    }
}

impl std::fmt::Display for FeatureKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One `T` per feature kind, indexed by kind (`v[FeatureKind::Ridge]`); serialised as
/// a map from the kinds' names (`{"ridge": …, "valley": …}`), and shown as one in logs.
#[derive(Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct PerKind<T>(pub [T; FeatureKind::COUNT]);

impl<T: std::fmt::Debug> std::fmt::Debug for PerKind<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_map().entries(self.iter().map(|(k, v)| (k.name(), v))).finish()
    }
}

impl<T> PerKind<T> {
    /// `f(kind)` for every kind.
    pub fn from_fn(mut f: impl FnMut(FeatureKind) -> T) -> Self {
        PerKind(std::array::from_fn(|i| f(FeatureKind::ALL[i])))
    }

    /// Each kind with its value, in index order.
    pub fn iter(&self) -> impl Iterator<Item = (FeatureKind, &T)> {
        FeatureKind::ALL.into_iter().zip(self.0.iter())
    }

    /// The values, in index order.
    pub fn values(&self) -> impl Iterator<Item = &T> {
        self.0.iter()
    }

    /// `f(kind, value)` for every kind.
    pub fn map<'a, U>(&'a self, mut f: impl FnMut(FeatureKind, &'a T) -> U) -> PerKind<U> {
        PerKind::from_fn(|k| f(k, &self[k]))
    }
}

impl<T: Copy + std::iter::Sum<T>> PerKind<T> {
    /// The values summed over every kind.
    pub fn total(&self) -> T {
        self.0.iter().copied().sum()
    }
}

impl<T> std::ops::Index<FeatureKind> for PerKind<T> {
    type Output = T;
    fn index(&self, k: FeatureKind) -> &T {
        &self.0[k.index()]
    }
}

impl<T> std::ops::IndexMut<FeatureKind> for PerKind<T> {
    fn index_mut(&mut self, k: FeatureKind) -> &mut T {
        &mut self.0[k.index()]
    }
}

impl<T: serde::Serialize> serde::Serialize for PerKind<T> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(FeatureKind::COUNT))?;
        for (k, v) in self.iter() {
            m.serialize_entry(k.name(), v)?;
        }
        m.end()
    }
}

impl<'de, T: serde::Deserialize<'de>> serde::Deserialize<'de> for PerKind<T> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let mut m: std::collections::BTreeMap<String, T> = serde::Deserialize::deserialize(d)?;
        if let Some(other) = m.keys().find(|n| FeatureKind::from_name(n).is_none()) {
            return Err(D::Error::custom(format!("'{other}' is not a feature kind")));
        }
        let mut values = Vec::with_capacity(FeatureKind::COUNT);
        for k in FeatureKind::ALL {
            values.push(m.remove(k.name()).ok_or_else(|| D::Error::custom(format!("no value for {k}")))?);
        }
        let arr: [T; FeatureKind::COUNT] = values.try_into().map_err(|_| D::Error::custom("wrong number of kinds"))?;
        Ok(PerKind(arr))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_index_name_and_serialise_as_a_map() {
        for (i, k) in FeatureKind::ALL.into_iter().enumerate() {
            assert_eq!(k.index(), i);
            assert_eq!(FeatureKind::from_index(i), Some(k));
            assert_eq!(FeatureKind::from_name(k.name()), Some(k));
            assert_eq!(k.inverted().inverted(), k);
            assert_eq!(k.inverted().sign(), -k.sign());
            assert!(k.stands_out(k.sign(), 0.0) && !k.stands_out(-k.sign(), 0.0));
        }
        let mut v = PerKind::from_fn(|k| k.index() * 10);
        v[FeatureKind::Valley] += 1;
        assert_eq!(v.0, [0, 11]);
        assert_eq!(v.total(), 11);
        let json = serde_json::to_string(&v).unwrap();
        assert_eq!(json, r#"{"ridge":0,"valley":11}"#);
        assert_eq!(serde_json::from_str::<PerKind<usize>>(&json).unwrap(), v);
        assert!(serde_json::from_str::<PerKind<usize>>(r#"{"ridge":1}"#).is_err(), "every kind needs a value");
        assert!(serde_json::from_str::<PerKind<usize>>(r#"{"ridge":1,"valley":2,"cliff":3}"#).is_err());
        assert_eq!(format!("{v:?}"), r#"{"ridge": 0, "valley": 11}"#);
    }
}
