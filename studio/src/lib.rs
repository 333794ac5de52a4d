//! FIT-SLAM studio (placeholder while it is written).
