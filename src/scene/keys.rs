//! The keys that several scene items share, declared once: the surface keys of a plane or a
//! cylinder (the other shape of a `[[contact]]`, a `[[shape]]`) and the contact-law keys (a
//! `[[contact]]`, a `[[contact_group]]`).
//!
//! `scene_item!` appends them to an item's own fields. They are not a `#[serde(flatten)]`
//! struct because flattening makes serde buffer the table: a TOML error in a shared key would
//! then point at the table's header instead of the key, and an unknown key would no longer be
//! told the keys it could have been.

/// Declares a scene item: `scene_item! { [surface_keys, law_keys] <struct> }` is the struct
/// with the surface keys, then the law keys, after its own fields (which end in a comma).
macro_rules! scene_item {
    ([] $($item:tt)*) => { $($item)* };
    ([$next:ident $(, $rest:ident)*] $($item:tt)*) => { $next! { [$($rest),*] $($item)* } };
}

/// Appends the surface keys of a plane (`origin`, `normal`, `u_axis`, `size`) and of a
/// cylinder (`axis_point` … `side`) to a `scene_item!`.
macro_rules! surface_keys {
    ([$($rest:ident),*] $(#[$meta:meta])* pub struct $name:ident { $($fields:tt)* }) => {
        scene_item! { [$($rest),*] $(#[$meta])* pub struct $name {
            $($fields)*
            /// Plane: centre of the rectangle \[m\].
            #[serde(default, deserialize_with = "crate::scene::exact::option_array")]
            pub origin: Option<[f64; 3]>,
            /// Plane: outward normal.
            #[serde(default, deserialize_with = "crate::scene::exact::option_array")]
            pub normal: Option<[f64; 3]>,
            /// Plane: first in-plane axis.
            #[serde(default, deserialize_with = "crate::scene::exact::option_array")]
            pub u_axis: Option<[f64; 3]>,
            /// Plane: side lengths [lu, lv] \[m\].
            #[serde(default, deserialize_with = "crate::scene::exact::option_array")]
            pub size: Option<[f64; 2]>,
            /// Cylinder: a point on the axis (the middle of the patch's length) \[m\].
            #[serde(default, deserialize_with = "crate::scene::exact::option_array")]
            pub axis_point: Option<[f64; 3]>,
            /// Cylinder: axis direction.
            #[serde(default, deserialize_with = "crate::scene::exact::option_array")]
            pub axis: Option<[f64; 3]>,
            /// Cylinder: radius ρ \[m\].
            pub cylinder_radius: Option<f64>,
            /// Cylinder: length of the patch along the axis \[m\].
            pub length: Option<f64>,
            /// Cylinder: angular range [min, max] from `ref_axis` \[rad\].
            #[serde(default, deserialize_with = "crate::scene::exact::option_array")]
            pub theta_range: Option<[f64; 2]>,
            /// Cylinder: direction (perpendicular to the axis) where θ = 0.
            #[serde(default, deserialize_with = "crate::scene::exact::option_array")]
            pub ref_axis: Option<[f64; 3]>,
            /// Cylinder: the side the spheres touch, outside (convex) or inside (concave).
            #[serde(default)]
            pub side: $crate::scene::Side,
        }}
        surface_checks!($name);
    };
}

/// The placement keys of a plane or cylinder surface, as an item gives them (world frame).
#[derive(Debug, Clone, Copy)]
pub struct Surface {
    /// Plane: centre of the rectangle.
    pub origin: Option<[f64; 3]>,
    /// Plane: outward normal.
    pub normal: Option<[f64; 3]>,
    /// Plane: first in-plane axis.
    pub u_axis: Option<[f64; 3]>,
    /// Cylinder: a point on the axis.
    pub axis_point: Option<[f64; 3]>,
    /// Cylinder: axis direction.
    pub axis: Option<[f64; 3]>,
    /// Cylinder: angular range \[rad\].
    pub theta_range: Option<[f64; 2]>,
    /// Cylinder: direction where θ = 0.
    pub ref_axis: Option<[f64; 3]>,
    /// Cylinder: the side the spheres touch.
    pub side: crate::scene::Side,
}

/// The checks of the surface keys, for an item with `surface_keys!`.
macro_rules! surface_checks {
    ($name:ident) => {
        impl $name {
            /// Where the surface is and which way it faces (its sizes are parameters).
            pub(crate) fn surface(&self) -> $crate::scene::keys::Surface {
                $crate::scene::keys::Surface {
                    origin: self.origin,
                    normal: self.normal,
                    u_axis: self.u_axis,
                    axis_point: self.axis_point,
                    axis: self.axis,
                    theta_range: self.theta_range,
                    ref_axis: self.ref_axis,
                    side: self.side,
                }
            }

            /// Checks every surface key given, whether or not the item's type uses it: points
            /// finite, directions nonzero, lengths positive, the extent ordered.
            pub(crate) fn check_surface_keys(&self, origin: &str, item: &str) -> Result<(), $crate::scene::SceneError> {
                use $crate::scene::rules::{direction, each_given, length, vector};
                use $crate::scene::validate::surface_extent;
                let points = [("origin", self.origin), ("axis_point", self.axis_point)];
                each_given(points, |f, v| vector(origin, item, f, &v))?;
                let directions = [
                    ("normal", self.normal),
                    ("u_axis", self.u_axis),
                    ("axis", self.axis),
                    ("ref_axis", self.ref_axis),
                ];
                each_given(directions, |f, v| direction(origin, item, f, v))?;
                let lengths = [("cylinder_radius", self.cylinder_radius), ("length", self.length)];
                each_given(lengths, |f, v| length(origin, item, f, v))?;
                surface_extent(origin, item, self.size, self.theta_range)
            }

            /// Refuses a surface key the item's type does not use, naming it: the plane's keys
            /// unless `plane`, the cylinder's (and `side = "inside"`) unless `cylinder`; `what`
            /// names the type in the message ("a plane shape"). (A key of another type was
            /// ignored without a word.)
            pub(crate) fn refuse_unused_surface_keys(
                &self,
                origin: &str,
                item: &str,
                (plane, cylinder): (bool, bool),
                what: &str,
            ) -> Result<(), $crate::scene::SceneError> {
                let plane_keys = [
                    ("origin", self.origin.is_some()),
                    ("normal", self.normal.is_some()),
                    ("u_axis", self.u_axis.is_some()),
                    ("size", self.size.is_some()),
                ];
                let cylinder_keys = [
                    ("axis_point", self.axis_point.is_some()),
                    ("axis", self.axis.is_some()),
                    ("cylinder_radius", self.cylinder_radius.is_some()),
                    ("length", self.length.is_some()),
                    ("theta_range", self.theta_range.is_some()),
                    ("ref_axis", self.ref_axis.is_some()),
                    ("side", self.side == $crate::scene::Side::Inside),
                ];
                let unused = (!plane).then_some(plane_keys).into_iter().flatten();
                let unused = unused.chain((!cylinder).then_some(cylinder_keys).into_iter().flatten());
                for (key, given) in unused {
                    if given {
                        return Err($crate::scene::SceneError::new(
                            origin,
                            item,
                            key,
                            format!("not used by {what}"),
                        ));
                    }
                }
                Ok(())
            }

            /// Checks that a plane has the keys it needs (`need` reports a missing one) and
            /// that its axes are perpendicular.
            pub(crate) fn check_plane(
                &self,
                origin: &str,
                item: &str,
                need: impl Fn(&str, bool) -> Result<(), $crate::scene::SceneError>,
            ) -> Result<(), $crate::scene::SceneError> {
                need("origin", self.origin.is_some())?;
                need("normal", self.normal.is_some())?;
                need("u_axis", self.u_axis.is_some())?;
                need("size", self.size.is_some())?;
                $crate::scene::validate::perpendicular((origin, item), ("u_axis", self.u_axis), ("normal", self.normal))
            }

            /// Checks that a cylinder has the keys it needs (`need` reports a missing one),
            /// `ref_axis` with `theta_range`, perpendicular to the axis.
            pub(crate) fn check_cylinder(
                &self,
                origin: &str,
                item: &str,
                need: impl Fn(&str, bool) -> Result<(), $crate::scene::SceneError>,
            ) -> Result<(), $crate::scene::SceneError> {
                need("axis_point", self.axis_point.is_some())?;
                need("axis", self.axis.is_some())?;
                need("cylinder_radius", self.cylinder_radius.is_some())?;
                need("length", self.length.is_some())?;
                if self.theta_range.is_some() && self.ref_axis.is_none() {
                    return Err($crate::scene::SceneError::new(
                        origin,
                        item,
                        "ref_axis",
                        "required with theta_range",
                    ));
                }
                if self.ref_axis.is_some() {
                    $crate::scene::validate::perpendicular(
                        (origin, item),
                        ("ref_axis", self.ref_axis),
                        ("axis", self.axis),
                    )?;
                }
                Ok(())
            }
        }
    };
}

/// Appends the contact-law keys after the law and the restitution (`stiffness` …
/// `stiction_velocity`) to a `scene_item!`.
macro_rules! law_keys {
    ([$($rest:ident),*] $(#[$meta:meta])* pub struct $name:ident { $($fields:tt)* }) => {
        scene_item! { [$($rest),*] $(#[$meta])* pub struct $name {
            $($fields)*
            /// Contact stiffness K \[N/m^n\]; when absent, the Hertz family derives it from the
            /// two materials (for a group pair, per pair of shapes).
            pub stiffness: Option<f64>,
            /// Kelvin-Voigt damping c \[N s/m\].
            pub damping: Option<f64>,
            /// Exponent n (default 1.5).
            pub exponent: Option<f64>,
            /// Largest admissible penetration \[m\] (default: the sphere radius).
            pub max_penetration: Option<f64>,
            /// Floor on the remembered impact velocity δ̇⁻ \[m/s\]; for the impulse law, approach
            /// speeds below it end in a resting contact.
            pub min_impact_velocity: Option<f64>,
            /// Impulse law only: `exact` (default) or `effective_mass` (paper (17)-(19)).
            #[serde(default)]
            pub impulse_method: $crate::scene::ImpulseMethod,
            /// Coulomb (sliding) friction coefficient μ (default 0: no friction).
            pub friction: Option<f64>,
            /// Static friction coefficient μ_s, the peak of the Stribeck curve (default μ).
            pub static_friction: Option<f64>,
            /// Stribeck velocity \[m/s\]: how fast μ_s decays to μ with the slip speed.
            pub stribeck_velocity: Option<f64>,
            /// Viscous friction coefficient σ \[s/m\] (friction coefficient grows by σ·|slip|).
            pub viscous_friction: Option<f64>,
            /// Regularisation velocity v_s \[m/s\] of the continuous friction law.
            pub stiction_velocity: Option<f64>,
        }}
    };
}
