//! JPEG decoded as libjpeg decodes it (issue 43): every repository JPEG, grey and colour, gives
//! exactly the bytes of libjpeg's default decode (Pillow's, `tests/data/vifb_jpeg/libjpeg/`,
//! made by `scripts/libjpeg_reference_decodes.py`); damaged JPEGs give one-line errors.

use fusion_io::{Channels, ColorPolicy, Picture, load_channels_u8, load_gray_u8, load_picture, testdata};
use std::path::Path;

const FILES: [(&str, &str, usize); 6] = [
    ("VI", "fight", 3),
    ("VI", "manWalking", 3),
    ("VI", "walkingnight", 3),
    ("IR", "fight", 3), // grey content stored as YCbCr
    ("IR", "manWalking", 1),
    ("IR", "walkingnight", 1),
];

/// Pixels (any channel) where `got` differs from `want`, and the first one's (x, y).
fn differing(got: &Channels, want: &Channels) -> (usize, Option<(usize, usize)>) {
    assert_eq!((got.width, got.height, got.planes.len()), (want.width, want.height, want.planes.len()));
    let n = got.width * got.height;
    let bad: Vec<usize> =
        (0..n).filter(|&i| got.planes.iter().zip(&want.planes).any(|(g, w)| g[i] != w[i])).collect();
    (bad.len(), bad.first().map(|&i| (i % got.width, i / got.width)))
}

#[test]
fn every_repository_jpeg_decodes_to_libjpegs_bytes() {
    let mut failures = Vec::new();
    for (band, name, channels) in FILES {
        let jpg = testdata::file(&format!("vifb_jpeg/{band}/{name}.jpg"));
        let reference = load_channels_u8(&testdata::file(&format!("vifb_jpeg/libjpeg/{band}_{name}.png")))
            .expect("the reference PNG");
        assert_eq!(reference.planes.len(), channels, "{band}/{name}: reference channels");
        let got = load_channels_u8(&jpg).unwrap();
        let (count, first) = differing(&got, &reference);
        if count > 0 {
            failures.push(format!(
                "{band}/{name}.jpg: {count} of {} pixels differ from libjpeg's, first at {first:?}",
                got.width * got.height
            ));
        }
        // load_picture gives the same thing (grey for 1-component files, RGB planes for colour).
        let same = match (load_picture(&jpg).unwrap(), channels) {
            (Picture::Gray8(g), 1) => g.data == got.planes[0],
            (Picture::Rgb8(c), 3) => c == got,
            (other, _) => panic!("{band}/{name}: {:?} from a {channels}-channel JPEG", other.size()),
        };
        assert!(same, "{band}/{name}: load_picture and load_channels_u8 disagree");
        // Grey from colour: BT.601 of libjpeg's RGB (MATLAB's rgb2gray(imread(…))).
        let grey = Channels::from_gray(load_gray_u8(&jpg, ColorPolicy::Bt601).unwrap());
        let (count, first) = differing(&grey, &Channels::from_gray(reference.to_gray()));
        if count > 0 && channels == 3 {
            failures.push(format!(
                "{band}/{name}.jpg in grey (BT.601): {count} pixels differ from libjpeg's, first at {first:?}"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn damaged_jpegs_give_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read(testdata::file("vifb_jpeg/VI/fight.jpg")).unwrap();
    let mut garbage = good.clone();
    let mid = garbage.len() / 2;
    let mut state = 0x2545_f491_4f6c_dd1d_u64; // xorshift: the same garbage every run
    for b in &mut garbage[mid..mid + 400] {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        *b = state as u8;
    }
    let cases: [(&str, Vec<u8>); 5] = [
        ("truncated", good[..good.len() / 2].to_vec()),
        ("few_hundred_bytes", good[..300].to_vec()),
        ("garbage_in_the_middle", garbage),
        ("empty", Vec::new()),
        ("not_a_jpeg", b"hello, this is text and not a JPEG at all\n".to_vec()),
    ];
    for (name, bytes) in cases {
        let path = dir.path().join(format!("{name}.jpg"));
        std::fs::write(&path, &bytes).unwrap();
        for result in [
            load_picture(&path).map(|_| ()),
            load_channels_u8(&path).map(|_| ()),
            fusion_io::image_header(&path).map(|_| ()),
        ] {
            if name == "truncated" || name == "garbage_in_the_middle" {
                // The header is intact: only decoding finds the damage.
                if result.is_ok() {
                    continue;
                }
            }
            let message = format!("{:#}", result.expect_err(name));
            assert!(!message.contains('\n'), "{name}: not one line: {message}");
            let expected = format!("{} is not a valid JPEG: ", path.display());
            assert!(message.starts_with(&expected), "{name}: {message}");
        }
        assert!(load_picture(&path).is_err(), "{name} decoded");
    }
}

#[test]
fn a_png_named_jpg_is_read_as_png() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("grey.jpg");
    let png = dir.path().join("grey.png");
    let img = fusion_io::Gray { width: 3, height: 1, data: vec![0u8, 128, 255] };
    fusion_io::save_gray_u8(&png, &img).unwrap();
    std::fs::rename(&png, &path).unwrap();
    assert_eq!(load_gray_u8(Path::new(&path), ColorPolicy::Refuse).unwrap(), img);
}

#[test]
fn a_cmyk_jpeg_is_refused_in_one_line() {
    // libjpeg decodes CMYK/YCCK only to CMYK (MATLAB's imread returns four channels): refused.
    let cmyk = turbojpeg::Image {
        pixels: [0u8, 64, 128, 255].repeat(16 * 16),
        width: 16,
        pitch: 16 * 4,
        height: 16,
        format: turbojpeg::PixelFormat::CMYK,
    };
    let bytes = turbojpeg::compress(cmyk.as_deref(), 90, turbojpeg::Subsamp::None).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cmyk.jpg");
    std::fs::write(&path, &bytes[..]).unwrap();
    let message = format!("{:#}", load_picture(&path).unwrap_err());
    assert_eq!(
        message,
        format!("{} is a CMYK JPEG; an 8-bit grey or colour one is needed here", path.display())
    );
}
