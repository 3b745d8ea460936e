//! Integer image filters shared by the fusion methods (one file per filter).

pub mod border;
pub mod box_sum;
pub mod erode;
pub mod gauss;
pub mod median3;
pub mod scharr;
