//! The part of a frame that holds the scene.
//!
//! A stream fused with scene skipping holds the method's output only inside its window; outside
//! it the core writes its background value, a flat level that is not space. The fusion reports
//! the window (`Report::skip`), or the navigation handed it in (the closed loop), so on board the
//! navigation knows where its image holds the scene, as the front end here does: it measures
//! its background, searches for edges and detects corners only inside that region, as it does
//! inside the image border of an unskipped frame.

/// A rectangle of pixels, `x0..x1` × `y0..y1` (exclusive ends).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Region {
    /// The whole of a `width` × `height` frame.
    pub fn whole(width: u32, height: u32) -> Region {
        Region { x0: 0, y0: 0, x1: width, y1: height }
    }

    /// Width, px.
    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    /// Height, px.
    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    /// The region `by` px inside this one on every side (empty when it is too small).
    pub fn shrunk(&self, by: u32) -> Region {
        let (x0, y0) = (self.x0 + by, self.y0 + by);
        Region { x0, y0, x1: self.x1.saturating_sub(by).max(x0), y1: self.y1.saturating_sub(by).max(y0) }
    }

    /// The part of the box `(x0, y0, x1, y1)` inside this region, `None` when they do not meet.
    pub fn clip(&self, b: (u32, u32, u32, u32)) -> Option<(u32, u32, u32, u32)> {
        let (x0, y0, x1, y1) = (b.0.max(self.x0), b.1.max(self.y0), b.2.min(self.x1), b.3.min(self.y1));
        (x1 > x0 && y1 > y0).then_some((x0, y0, x1, y1))
    }

    /// Whether the continuous point `(u, v)` (pixel centres at `x + 0.5`) is at least `margin`
    /// px inside the region.
    pub fn holds(&self, u: f64, v: f64, margin: f64) -> bool {
        u >= f64::from(self.x0) + margin
            && v >= f64::from(self.y0) + margin
            && u < f64::from(self.x1) - margin
            && v < f64::from(self.y1) - margin
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shrink_clip_and_hold_by_hand() {
        let r = Region { x0: 10, y0: 20, x1: 50, y1: 40 };
        assert_eq!((r.width(), r.height()), (40, 20));
        let s = r.shrunk(5);
        assert_eq!(s, Region { x0: 15, y0: 25, x1: 45, y1: 35 });
        assert_eq!(r.shrunk(15).height(), 0);
        assert_eq!(r.clip((0, 0, 30, 100)), Some((10, 20, 30, 40)));
        assert_eq!(r.clip((50, 0, 60, 100)), None);
        assert!(r.holds(10.0, 20.0, 0.0) && !r.holds(50.0, 30.0, 0.0));
        assert!(r.holds(12.0, 30.0, 2.0) && !r.holds(11.9, 30.0, 2.0) && !r.holds(30.0, 38.5, 2.0));
    }
}
