//! Spatial (6-D) vectors in Plücker coordinates taken at the world origin, world frame.
//!
//! A motion vector is `(ω, v_O)`: angular velocity and the velocity of the body-fixed point
//! that currently coincides with the world origin. A force vector is `(n_O, f)`: moment about
//! the origin and resultant force. Because every body uses the same frame, transporting a
//! vector from one body to another needs no transform; only the inertias depend on the pose.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// A motion (velocity or acceleration) or force vector: `ang` then `lin`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Spatial {
    /// Angular part (ω, or moment about the origin).
    pub ang: Vector3<f64>,
    /// Linear part (v_O, or force).
    pub lin: Vector3<f64>,
}

impl Spatial {
    /// Zero vector.
    pub fn zero() -> Spatial {
        Spatial {
            ang: Vector3::zeros(),
            lin: Vector3::zeros(),
        }
    }
    /// From parts.
    pub fn new(ang: Vector3<f64>, lin: Vector3<f64>) -> Spatial {
        Spatial { ang, lin }
    }
    /// Scaled copy.
    pub fn scale(&self, s: f64) -> Spatial {
        Spatial {
            ang: self.ang * s,
            lin: self.lin * s,
        }
    }
    /// Sum.
    pub fn add(&self, o: &Spatial) -> Spatial {
        Spatial {
            ang: self.ang + o.ang,
            lin: self.lin + o.lin,
        }
    }
    /// Difference.
    pub fn sub(&self, o: &Spatial) -> Spatial {
        Spatial {
            ang: self.ang - o.ang,
            lin: self.lin - o.lin,
        }
    }
    /// Pairing of a motion and a force vector (power).
    pub fn dot(&self, o: &Spatial) -> f64 {
        self.ang.dot(&o.ang) + self.lin.dot(&o.lin)
    }
    /// Motion cross product `self ×ₘ m` (rate of change of a motion vector fixed in a body
    /// moving with velocity `self`).
    pub fn cross_motion(&self, m: &Spatial) -> Spatial {
        Spatial {
            ang: self.ang.cross(&m.ang),
            lin: self.ang.cross(&m.lin) + self.lin.cross(&m.ang),
        }
    }
    /// Force cross product `self ×* f`.
    pub fn cross_force(&self, f: &Spatial) -> Spatial {
        Spatial {
            ang: self.ang.cross(&f.ang) + self.lin.cross(&f.lin),
            lin: self.ang.cross(&f.lin),
        }
    }
    /// Velocity (or spatial-acceleration part) of the body point at `p`: `v_O + ω × p`.
    pub fn point_velocity(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.lin + self.ang.cross(p)
    }
    /// The force vector of a force `f` acting at point `p`.
    pub fn force_at(f: &Vector3<f64>, p: &Vector3<f64>) -> Spatial {
        Spatial {
            ang: p.cross(f),
            lin: *f,
        }
    }
    /// The coefficient vector `c` such that `c · V` is the velocity of point `p` along `dir`
    /// for a body with motion `V`.
    pub fn point_direction(p: &Vector3<f64>, dir: &Vector3<f64>) -> Spatial {
        Spatial {
            ang: p.cross(dir),
            lin: *dir,
        }
    }
}

/// Classical acceleration of the body point at `p`, from the body's spatial acceleration `a`
/// and spatial velocity `v`: `a_O + α × p + ω × v_p`.
pub fn point_acceleration(a: &Spatial, v: &Spatial, p: &Vector3<f64>) -> Vector3<f64> {
    a.point_velocity(p) + v.ang.cross(&v.point_velocity(p))
}

/// Spatial inertia of a rigid body about the world origin, stored compactly:
/// mass, first moment `m c` and rotational inertia about the origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inertia {
    /// Mass \[kg\].
    pub mass: f64,
    /// First moment of mass about the origin, `m c` \[kg m\].
    pub h: Vector3<f64>,
    /// Rotational inertia about the origin \[kg m^2\].
    pub i_o: Matrix3<f64>,
}

impl Inertia {
    /// Zero inertia.
    pub fn zero() -> Inertia {
        Inertia {
            mass: 0.0,
            h: Vector3::zeros(),
            i_o: Matrix3::zeros(),
        }
    }
    /// From mass, centre of mass `c` and world-frame inertia about the centre of mass.
    pub fn from_body(mass: f64, c: &Vector3<f64>, i_c: &Matrix3<f64>) -> Inertia {
        // −[c]×[c]× = |c|² 1 − c cᵀ (parallel axes)
        let mc = c * mass;
        let mut i_o = *i_c - mc * c.transpose();
        let c2 = mass * c.norm_squared();
        for k in 0..3 {
            i_o[(k, k)] += c2;
        }
        Inertia { mass, h: mc, i_o }
    }
    /// Momentum (a force vector) of motion `v`.
    pub fn mul(&self, v: &Spatial) -> Spatial {
        Spatial {
            ang: self.i_o * v.ang + self.h.cross(&v.lin),
            lin: v.lin * self.mass - self.h.cross(&v.ang),
        }
    }
    /// Sum of two inertias (composite body).
    pub fn add_assign(&mut self, o: &Inertia) {
        self.mass += o.mass;
        self.h += o.h;
        self.i_o += o.i_o;
    }
}

/// Pose and motion of a body, or of the ground.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    /// Centre of mass (origin for ground).
    pub pos: Vector3<f64>,
    /// Rotation body → world.
    pub rot: Matrix3<f64>,
    /// Orientation.
    pub quat: UnitQuaternion<f64>,
    /// Spatial velocity.
    pub vel: Spatial,
    /// Spatial bias acceleration.
    pub acc: Spatial,
}

impl Frame {
    /// The fixed world frame (the ground).
    pub fn ground() -> Frame {
        Frame {
            pos: Vector3::zeros(),
            rot: Matrix3::identity(),
            quat: UnitQuaternion::identity(),
            vel: Spatial::zero(),
            acc: Spatial::zero(),
        }
    }
}

/// A body's pose and velocity by reference, as contact detection reads them: a [`Frame`]
/// without its copy. `None` in its place stands for the ground, at rest in the world frame,
/// whose identity rotation and zero velocity are then not multiplied out.
#[derive(Debug, Clone, Copy)]
pub struct Placement<'a> {
    /// Centre of mass.
    pub pos: &'a Vector3<f64>,
    /// Rotation body → world.
    pub rot: &'a Matrix3<f64>,
    /// Spatial velocity.
    pub vel: &'a Spatial,
}

impl<'a> Placement<'a> {
    /// The placement of a frame.
    pub fn of(f: &'a Frame) -> Placement<'a> {
        Placement {
            pos: &f.pos,
            rot: &f.rot,
            vel: &f.vel,
        }
    }

    /// World position of the point `x` fixed in the body (`None`: the ground, `x` is world).
    /// A point at the centre of mass is the centre itself (no rotation).
    #[inline]
    pub fn point(p: Option<Placement>, x: &Vector3<f64>) -> Vector3<f64> {
        match p {
            None => *x,
            Some(p) if *x == Vector3::zeros() => *p.pos,
            Some(p) => p.pos + p.rot * x,
        }
    }

    /// World direction of the direction `x` fixed in the body.
    #[inline]
    pub fn direction(p: Option<Placement>, x: &Vector3<f64>) -> Vector3<f64> {
        match p {
            None => *x,
            Some(p) => p.rot * x,
        }
    }

    /// Velocity of the body's material point at the world position `x`.
    #[inline]
    pub fn point_velocity(p: Option<Placement>, x: &Vector3<f64>) -> Vector3<f64> {
        match p {
            None => Vector3::zeros(),
            Some(p) => p.vel.point_velocity(x),
        }
    }
}

/// An orthonormal triad whose first column is `axis`.
pub fn triad(axis: &Vector3<f64>) -> Matrix3<f64> {
    let a = axis.normalize();
    let t = if a.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
    let u1 = a.cross(&t).normalize();
    let u2 = a.cross(&u1);
    Matrix3::from_columns(&[a, u1, u2])
}
