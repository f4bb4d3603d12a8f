//! What generated message types need beyond serde's defaults: `wstring` as ROS 2 puts it on the wire, and
//! fixed arrays of any length.

use serde::{
    de::{Error as _, SeqAccess, Visitor},
    ser::SerializeTuple,
    Deserialize, Deserializer, Serialize, Serializer,
};

/// A `wstring` field: text that ROS 2 (rmw_fastrtps, rclpy) puts on the wire as its UTF-16 code units, each
/// as a 4-byte `wchar`, after a 4-byte count.
///
/// ```
/// use radar_ros::msg::WString;
/// let w = WString::from("grüße");
/// assert_eq!(w.as_str(), "grüße");
/// ```
#[derive(Clone, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct WString(pub String);

impl WString {
    /// The text.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl From<&str> for WString {
    fn from(s: &str) -> Self {
        WString(s.to_owned())
    }
}

impl From<String> for WString {
    fn from(s: String) -> Self {
        WString(s)
    }
}

impl std::fmt::Display for WString {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl Serialize for WString {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let units: Vec<u32> = self.0.encode_utf16().map(u32::from).collect();
        units.serialize(s)
    }
}

impl<'de> Deserialize<'de> for WString {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let units = Vec::<u32>::deserialize(d)?;
        let units: Vec<u16> = units
            .into_iter()
            .map(|u| u16::try_from(u).map_err(|_| D::Error::custom("a wstring unit over 0xFFFF")))
            .collect::<Result<_, _>>()?;
        String::from_utf16(&units)
            .map(WString)
            .map_err(|_| D::Error::custom("a wstring that is no UTF-16"))
    }
}

/// `#[serde(with = "radar_ros::msg::fixed_array")]`: a fixed-size array field (`float64[36] covariance`) of any
/// length, written as CDR writes one: its elements, without a count (serde's own impls stop at 32).
pub mod fixed_array {
    use super::*;

    /// Writes the elements.
    pub fn serialize<S: Serializer, T: Serialize, const N: usize>(
        a: &[T; N],
        s: S,
    ) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(N)?;
        for x in a {
            t.serialize_element(x)?;
        }
        t.end()
    }

    /// Reads `N` elements.
    pub fn deserialize<'de, D: Deserializer<'de>, T: Deserialize<'de>, const N: usize>(
        d: D,
    ) -> Result<[T; N], D::Error> {
        struct Elements<T, const N: usize>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for Elements<T, N> {
            type Value = [T; N];
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "an array of {N} elements")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<[T; N], A::Error> {
                let mut v = Vec::with_capacity(N);
                for i in 0..N {
                    v.push(
                        seq.next_element()?
                            .ok_or_else(|| A::Error::invalid_length(i, &self))?,
                    );
                }
                v.try_into()
                    .map_err(|_| A::Error::custom("an array of the wrong length"))
            }
        }
        d.deserialize_tuple(N, Elements::<T, N>(std::marker::PhantomData))
    }
}
