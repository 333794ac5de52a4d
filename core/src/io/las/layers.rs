//! LAZ layered chunks (LASzip's item versions 3 and 4, point formats 6–10), checked before the
//! `laz` decoder reads them.
//!
//! Each chunk of layered points is: the chunk's first point raw (one record), a `u32` point
//! count, one `u32` byte size per layer of every item (point14: 9 layers; rgb14: 1; rgbnir14: 2;
//! wavepacket14: 1; byte14: one per extra byte), then the layers themselves. The decoder sizes a
//! buffer for each layer from its declared size before it reads it, so a corrupt size of up to
//! 4 GiB is allocated in full even when the file holds a few hundred bytes. Walking the chunks
//! one after another (the order the decoder reads them in) and requiring that each chunk's layers
//! fit in what is left of the point data bounds every such buffer by the file size. O(chunks).

use super::{las_err, u16_at, u32_at};
use crate::io::CloudError;

/// The LASzip VLR: user id and record id.
const LASZIP_USER_ID: &[u8] = b"laszip encoded";
const LASZIP_RECORD_ID: u16 = 22204;
/// Bytes of a VLR header; of the LASzip VLR's fixed part, before its item list.
const VLR_HEADER_LEN: usize = 54;
const LASZIP_ITEMS_AT: usize = 32;

/// Layers of one LASzip item, `None` for an item that is not layered (version < 3).
fn layers(item_type: u16, size: u16, version: u16) -> Option<u64> {
    if version < 3 {
        return None;
    }
    match item_type {
        10 => Some(9),               // point14
        11 | 13 => Some(1),          // rgb14, wavepacket14
        12 => Some(2),               // rgbnir14
        14 => Some(u64::from(size)), // byte14: one layer per extra byte
        _ => None,
    }
}

/// The LASzip VLR's data, if the file has one.
fn laszip_vlr(bytes: &[u8]) -> Option<&[u8]> {
    let mut at = usize::from(u16_at(bytes, 94)?);
    for _ in 0..u32_at(bytes, 100)? {
        let user_id = bytes.get(at + 2..at + 18)?;
        let record_id = u16_at(bytes, at + 18)?;
        let len = usize::from(u16_at(bytes, at + 20)?);
        let data = bytes.get(at + VLR_HEADER_LEN..at + VLR_HEADER_LEN + len)?;
        if user_id.starts_with(LASZIP_USER_ID) && record_id == LASZIP_RECORD_ID {
            return Some(data);
        }
        at += VLR_HEADER_LEN + len;
    }
    None
}

/// `Err` when a layered chunk declares more layer bytes than the point data has left.
/// `data_start` is the public header's offset to the point data; `data_end` where the point data
/// ends (the chunk table, or the end of the file).
pub(super) fn check_layered_chunks(bytes: &[u8], data_start: u64, data_end: u64, name: &str) -> Result<(), CloudError> {
    let Some(vlr) = laszip_vlr(bytes) else { return Ok(()) };
    let Some(count) = u16_at(vlr, LASZIP_ITEMS_AT) else { return Ok(()) };
    let (mut record_len, mut layer_count) = (0u64, 0u64);
    for i in 0..usize::from(count) {
        let at = LASZIP_ITEMS_AT + 2 + 6 * i;
        let (Some(item_type), Some(size), Some(version)) = (u16_at(vlr, at), u16_at(vlr, at + 2), u16_at(vlr, at + 4)) else {
            return Ok(());
        };
        record_len += u64::from(size);
        layer_count += layers(item_type, size, version).unwrap_or(0);
    }
    if layer_count == 0 {
        return Ok(());
    }
    // The point data starts with the chunk table's offset (8 bytes), then the first chunk.
    let sizes_at = record_len + 4;
    let chunk_header = sizes_at + 4 * layer_count;
    let mut at = data_start.saturating_add(8);
    while at.saturating_add(chunk_header) <= data_end {
        let mut layer_bytes = 0u64;
        for k in 0..layer_count {
            let size_at = usize::try_from(at + sizes_at + 4 * k).unwrap_or(usize::MAX);
            layer_bytes += u64::from(u32_at(bytes, size_at).unwrap_or(0));
        }
        let left = data_end - at - chunk_header;
        if layer_bytes > left {
            return Err(las_err(name, format!("LAZ chunk at byte {at} declares {layer_bytes} bytes of layers, {left} are left")));
        }
        at += chunk_header + layer_bytes;
    }
    Ok(())
}
