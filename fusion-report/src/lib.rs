//! # fusion-report
//!
//! What a person looks at: charts ([`plot`], drawn with `plotters`: PNG with a TrueType font
//! found on the machine, SVG otherwise) and contact sheets ([`sheet`]: tiles cropped to the
//! target, laid out in rows, labelled on the image). Written through `fusion_io`'s atomic
//! write path.
//!
//! ```
//! use fusion_io::Gray;
//! use fusion_report::sheet::contact_sheet;
//!
//! let dark = Gray { width: 4, height: 4, data: vec![0u8; 16] };
//! let light = Gray { width: 4, height: 4, data: vec![255u8; 16] };
//! let sheet = contact_sheet(&[vec![dark.clone(), light.clone()], vec![light, dark]], 2);
//! // Two rows of two 4-px tiles with 2-px gaps of mid grey around and between them.
//! assert_eq!((sheet.width, sheet.height), (2 * 4 + 3 * 2, 2 * 4 + 3 * 2));
//! assert_eq!(sheet.data[0], 128);
//! ```

pub mod plot;
pub mod sheet;
