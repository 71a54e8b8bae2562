//! Lobe sets: which kinds of scattering a BSDF can produce (Mitsuba's `BSDFFlags`), as a typed bit
//! set, and the one rule that derives a node's set from its kind and its children's sets
//! ([`BsdfNode::lobes`](super::BsdfNode::lobes)), used both by the material table at load time and
//! by the per-hit arena.

use std::ops::{BitAnd, BitOr, BitOrAssign};

/// A set of lobes. A sample reports the one lobe that produced it; a BSDF reports the union of
/// the lobes it can produce on either side.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Lobes(u32);

impl Lobes {
    pub const EMPTY: Lobes = Lobes(0);
    pub const DIFFUSE_REFLECTION: Lobes = Lobes(1 << 0);
    pub const GLOSSY_REFLECTION: Lobes = Lobes(1 << 1);
    pub const DELTA_REFLECTION: Lobes = Lobes(1 << 2);
    pub const DIFFUSE_TRANSMISSION: Lobes = Lobes(1 << 3);
    pub const GLOSSY_TRANSMISSION: Lobes = Lobes(1 << 4);
    pub const DELTA_TRANSMISSION: Lobes = Lobes(1 << 5);
    /// Index-matched pass-through (`null`, `mask`): the ray continues unchanged.
    pub const NULL: Lobes = Lobes(1 << 6);
    pub const REFLECTION: Lobes =
        Lobes(Self::DIFFUSE_REFLECTION.0 | Self::GLOSSY_REFLECTION.0 | Self::DELTA_REFLECTION.0);
    pub const TRANSMISSION: Lobes = Lobes(
        Self::DIFFUSE_TRANSMISSION.0
            | Self::GLOSSY_TRANSMISSION.0
            | Self::DELTA_TRANSMISSION.0
            | Self::NULL.0,
    );
    pub const DELTA: Lobes =
        Lobes(Self::DELTA_REFLECTION.0 | Self::DELTA_TRANSMISSION.0 | Self::NULL.0);
    /// Lobes that next-event estimation can evaluate (non-delta).
    pub const SMOOTH: Lobes = Lobes(
        Self::DIFFUSE_REFLECTION.0
            | Self::GLOSSY_REFLECTION.0
            | Self::DIFFUSE_TRANSMISSION.0
            | Self::GLOSSY_TRANSMISSION.0,
    );

    /// The raw bits (Mitsuba's `BSDFFlags` values for the lobes groove has).
    #[inline]
    pub const fn bits(self) -> u32 {
        self.0
    }

    /// True when the two sets share a lobe.
    #[inline]
    pub const fn intersects(self, other: Lobes) -> bool {
        self.0 & other.0 != 0
    }

    /// True when every lobe of `other` is in the set.
    #[inline]
    pub const fn contains(self, other: Lobes) -> bool {
        self.0 & other.0 == other.0
    }

    #[inline]
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Has a lobe that next-event estimation can evaluate.
    #[inline]
    pub const fn is_smooth(self) -> bool {
        self.intersects(Self::SMOOTH)
    }

    /// Has a delta lobe (specular reflection or refraction, or pass-through).
    #[inline]
    pub const fn has_delta(self) -> bool {
        self.intersects(Self::DELTA)
    }

    /// Has a transmitting lobe (pass-through included).
    #[inline]
    pub const fn has_transmission(self) -> bool {
        self.intersects(Self::TRANSMISSION)
    }

    /// Has a reflecting lobe.
    #[inline]
    pub const fn has_reflection(self) -> bool {
        self.intersects(Self::REFLECTION)
    }
}

impl BitOr for Lobes {
    type Output = Lobes;
    #[inline]
    fn bitor(self, o: Lobes) -> Lobes {
        Lobes(self.0 | o.0)
    }
}

impl BitOrAssign for Lobes {
    #[inline]
    fn bitor_assign(&mut self, o: Lobes) {
        self.0 |= o.0;
    }
}

impl BitAnd for Lobes {
    type Output = Lobes;
    #[inline]
    fn bitand(self, o: Lobes) -> Lobes {
        Lobes(self.0 & o.0)
    }
}

#[cfg(test)]
mod tests {
    use super::Lobes;

    #[test]
    fn groups_partition_the_lobes() {
        let all = Lobes::REFLECTION | Lobes::TRANSMISSION;
        assert_eq!(all.bits(), 0x7f);
        assert!(!Lobes::REFLECTION.intersects(Lobes::TRANSMISSION));
        assert_eq!(Lobes::SMOOTH | Lobes::DELTA, all);
        assert!(!Lobes::SMOOTH.intersects(Lobes::DELTA));
        assert!(Lobes::DELTA.contains(Lobes::NULL));
        assert!(!Lobes::NULL.contains(Lobes::DELTA));
        assert!(Lobes::EMPTY.is_empty() && !Lobes::EMPTY.is_smooth());
        let plastic = Lobes::DELTA_REFLECTION | Lobes::DIFFUSE_REFLECTION;
        assert!(plastic.is_smooth() && plastic.has_delta() && !plastic.has_transmission());
    }
}
