//! Which LAS classes are water: the returns from below the surface (refracted beams) that the
//! conic TPU treats as soundings and that `lidarqa trajectory` leaves out of its lines.
//!
//! The default is the LAS 1.4 (R15) topo-bathy classes below the surface — 40 bathymetric
//! point, 43 submerged object, 44 IHO S-57 object, 45 no-bottom-found — and class 26, which
//! RIEGL's and LP360's exports use for bathymetry (ASPRS reserves it, so it clashes with no
//! standard class). 41 (water surface) and 42 (derived water surface) are not below the surface.
//! `--water-classes` replaces the list; every summary that met such points names what it
//! assumed.

use lidarqa_model::Warning;

/// The default sub-surface classes.
pub const DEFAULT_WATER_CLASSES: [u8; 5] = [40, 43, 44, 45, 26];

/// The classes of returns from below the water surface.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WaterClasses {
    classes: Vec<u8>,
    /// Given by the user (else the default).
    pub given: bool,
}

impl Default for WaterClasses {
    fn default() -> Self {
        WaterClasses {
            classes: DEFAULT_WATER_CLASSES.to_vec(),
            given: false,
        }
    }
}

impl WaterClasses {
    /// The user's list (`--water-classes 40,26`).
    pub fn given(classes: Vec<u8>) -> WaterClasses {
        WaterClasses {
            classes,
            given: true,
        }
    }

    /// The user's list, `None` for the default.
    pub fn given_list(&self) -> Option<Vec<u8>> {
        self.given.then(|| self.classes.clone())
    }

    /// A return of class `c` is from below the water surface.
    #[inline]
    pub fn contains(&self, c: u8) -> bool {
        self.classes.contains(&c)
    }

    /// The classes, e.g. "40, 43, 44, 45, 26".
    pub fn list(&self) -> String {
        self.classes
            .iter()
            .map(u8::to_string)
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The warning naming what was assumed when `n` points of `what` were in these classes.
    pub fn note(&self, n: u64, what: &str) -> Option<Warning> {
        (n > 0).then(|| {
            let source = if self.given {
                "as given with --water-classes".to_string()
            } else {
                "by default: LAS 1.4 topo-bathy classes 40, 43, 44, 45 and class 26 of RIEGL / \
                 LP360 exports; set others with --water-classes"
                    .to_string()
            };
            Warning::new(
                "water_classes",
                format!(
                    "{n} points in classes {} taken as returns from below the water surface \
                     ({source}): {what}",
                    self.list()
                ),
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_names_the_las_classes_and_class_26() {
        let w = WaterClasses::default();
        assert!(w.contains(40) && w.contains(26) && !w.contains(41) && !w.contains(2));
        let n = w.note(3, "left out").unwrap();
        assert_eq!(n.code, "water_classes");
        assert!(n.message.contains("class 26 of RIEGL"), "{}", n.message);
        assert!(w.note(0, "x").is_none());
        let g = WaterClasses::given(vec![9]);
        assert!(g.contains(9) && !g.contains(40));
        assert!(g.note(1, "x").unwrap().message.contains("--water-classes"));
    }
}
