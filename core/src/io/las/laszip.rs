//! The LASzip VLR and the layered chunks of a LAZ file, checked before the `laz` decoder trusts
//! them.
//!
//! The items' sizes must add up to the header's point record length: the decoder builds one
//! model per declared extra byte (a 65,535-byte item costs a quarter of a gigabyte) and sums the
//! sizes in a `u16`.
//!
//! Layered chunks (item versions 3 and 4, point formats 6–10): each chunk of layered points is: the chunk's first point raw (each item's own size), a `u32` point
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

/// One layered LASzip item as the decoder reads it: the bytes of its raw first point and its
/// number of layers; `None` for an item that is not layered (version < 3). The raw size is the
/// decoder's own for each type, whatever size the VLR declares (only byte14 takes it from there).
fn layered(item_type: u16, size: u16, version: u16) -> Option<(u64, u64)> {
    if version < 3 {
        return None;
    }
    match item_type {
        10 => Some((30, 9)),                            // point14
        11 => Some((6, 1)),                             // rgb14
        12 => Some((8, 2)),                             // rgbnir14
        13 => Some((29, 1)),                            // wavepacket14
        14 => Some((u64::from(size), u64::from(size))), // byte14: a layer per extra byte
        _ => None,
    }
}

/// The LASzip VLR's data, if the file has one. The VLRs follow the public header, which the
/// `las` crate reads at its version's size or at the declared size when that is larger.
fn laszip_vlr(bytes: &[u8]) -> Option<&[u8]> {
    let version_len = match (bytes.get(24)?, bytes.get(25)?) {
        (1, 0..=2) | (0, _) => 227,
        (1, 3) => 235,
        _ => 375,
    };
    let mut at = usize::from(u16_at(bytes, 94)?).max(version_len);
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

/// `Err` when the LASzip items do not describe `record_len`-byte points, or a layered chunk
/// declares more layer bytes than the point data has left. `data_start` is the public header's
/// offset to the point data; `data_end` where the point data ends (the chunk table, or the end of
/// the file). A file without a readable LASzip VLR is left to the decoder's own errors.
pub(super) fn check_laszip(bytes: &[u8], record_len: u64, data_start: u64, data_end: u64, name: &str) -> Result<(), CloudError> {
    let Some(vlr) = laszip_vlr(bytes) else { return Ok(()) };
    let Some(count) = u16_at(vlr, LASZIP_ITEMS_AT) else { return Ok(()) };
    let (mut items_len, mut raw_len, mut layer_count) = (0u64, 0u64, 0u64);
    for i in 0..usize::from(count) {
        let at = LASZIP_ITEMS_AT + 2 + 6 * i;
        let (Some(item_type), Some(size), Some(version)) = (u16_at(vlr, at), u16_at(vlr, at + 2), u16_at(vlr, at + 4)) else {
            return Ok(());
        };
        items_len += u64::from(size);
        if let Some((raw, layers)) = layered(item_type, size, version) {
            raw_len += raw;
            layer_count += layers;
        }
    }
    if items_len != record_len {
        return Err(las_err(name, format!("LAZ items describe {items_len}-byte points, the header {record_len}-byte ones")));
    }
    if layer_count == 0 {
        return Ok(());
    }
    // The point data starts with the chunk table's offset (8 bytes), then the first chunk.
    let sizes_at = raw_len + 4;
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
