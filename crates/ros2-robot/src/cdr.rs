//! Plain CDR (little-endian, the payload after RTPS's 4-byte encapsulation header), as ROS 2
//! writes it.

use ros2_client::dds::rustdds::RepresentationIdentifier;
use ros2_client::dds::rustdds::serialization::{
    deserialize_from_cdr_with_rep_id, to_writer_with_rep_id,
};
use serde::Serialize;
use serde::de::DeserializeOwned;

/// The CDR payload of `value`.
pub fn to_bytes<T: Serialize>(value: &T) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    to_writer_with_rep_id(&mut bytes, value, RepresentationIdentifier::CDR_LE)
        .map_err(|e| e.to_string())?;
    Ok(bytes)
}

/// A value from a CDR payload, which it must fill to the end (up to CDR's 4-byte padding).
pub fn from_bytes<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, String> {
    let (value, used) =
        deserialize_from_cdr_with_rep_id::<T>(bytes, RepresentationIdentifier::CDR_LE)
            .map_err(|e| e.to_string())?;
    if bytes.len() - used >= 4 {
        return Err(format!(
            "{} bytes left over after {used}",
            bytes.len() - used
        ));
    }
    Ok(value)
}
