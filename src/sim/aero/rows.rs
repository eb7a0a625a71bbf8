//! The air phase in scene order, for any solver: positions read as 16-byte
//! rows `[x, y, z, 0]` ([`Solver::read_rows`]), eight rows transposed into
//! lanes for each group of particles (`noise`) or triangle corners
//! (`force`), and each particle's sum of its triangles' thirds pushed back
//! through [`Solver::push`].

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use super::noise::{self, Field};
use super::{AeroStep, TRIANGLES, force};
use crate::sim::csr::csr;
use crate::sim::step::Solver;

/// Particles a task of the thread pool takes for the air's velocity.
const CHUNK: usize = 2048;

#[derive(Clone, Debug)]
pub(super) struct RowForm {
    /// The mesh's triangles (scene indices).
    triangles: Vec<[u32; 3]>,
    /// m_t of each triangle, kg.
    triangle_mass: Vec<f32>,
    /// A third of each triangle's force, N, as rows.
    third_force: Vec<[f32; 4]>,
    /// Incident triangles of particle i:
    /// `incident[offsets[i]..offsets[i + 1]]`, in the mesh's order.
    offsets: Vec<u32>,
    incident: Vec<u32>,
    /// Positions x.
    x: Vec<[f32; 4]>,
    /// Positions one substep ago.
    x_prev: Vec<[f32; 4]>,
    /// u_i = v_air(x_i) − v_i per particle, m/s.
    relative: Vec<[f32; 4]>,
    /// (h/n)² F_i / m̄ per particle, m.
    push: Vec<Vec3>,
}

impl RowForm {
    pub(super) fn new(particles: usize, triangles: &[[u32; 3]], triangle_mass: Vec<f32>) -> Self {
        let corners = triangles.iter().enumerate().flat_map(|(k, t)| t.map(|i| (i, k as u32)));
        let (offsets, incident) = csr(particles, corners);
        Self {
            third_force: vec![[0.0; 4]; triangles.len()],
            triangles: triangles.to_vec(),
            triangle_mass,
            offsets,
            incident,
            x: vec![[0.0; 4]; particles],
            x_prev: vec![[0.0; 4]; particles],
            relative: vec![[0.0; 4]; particles],
            push: vec![Vec3::ZERO; particles],
        }
    }

    pub(super) fn compute(&mut self, solver: &dyn Solver, step: &AeroStep, gusts: &Field, parallel: bool) {
        let Self { triangles, triangle_mass, third_force, offsets, incident, x, x_prev, relative, push } = self;
        let (air, dt) = (step.air, step.dt);
        solver.read_rows(x, x_prev);
        // The air's velocity relative to each particle, v_air(x) −
        // (x − x_prev)/(h/n): chunks in scene order, each with its own cell
        // cache (neighbours mostly share a cell of the noise).
        type Chunk<'a> = (&'a mut [[f32; 4]], (&'a [[f32; 4]], &'a [[f32; 4]]));
        let field = |(u, (x, x_prev)): Chunk| noise::relative_air(gusts, dt, x, x_prev, u);
        if parallel {
            let x = x.par_chunks(CHUNK).zip(x_prev.par_chunks(CHUNK));
            relative.par_chunks_mut(CHUNK).zip(x).for_each(field);
        } else {
            let x = x.chunks(CHUNK).zip(x_prev.chunks(CHUNK));
            relative.chunks_mut(CHUNK).zip(x).for_each(field);
        }
        // A third of each triangle's force, eight triangles at a time.
        let (x, relative) = (&*x, &*relative);
        type Triangles<'a> = (&'a mut [[f32; 4]], (&'a [[u32; 3]], &'a [f32]));
        let chunk = |(out, (triangles, masses)): Triangles| {
            force::third_forces(&air, dt, x, relative, triangles, masses, out);
        };
        if parallel {
            let t = triangles.par_chunks(TRIANGLES).zip(triangle_mass.par_chunks(TRIANGLES));
            third_force.par_chunks_mut(TRIANGLES).zip(t).for_each(chunk);
        } else {
            let t = triangles.chunks(TRIANGLES).zip(triangle_mass.chunks(TRIANGLES));
            third_force.chunks_mut(TRIANGLES).zip(t).for_each(chunk);
        }
        // Each particle's sum of its triangles' thirds, four lanes at once
        // (w is 0), each the sum of one coordinate.
        let scale = step.displacement_per_newton;
        let (offsets, incident, forces) = (&*offsets, &*incident, &*third_force);
        let gather = |(i, p): (usize, &mut Vec3)| {
            let range = offsets[i] as usize..offsets[i + 1] as usize;
            let sum = incident[range].iter().map(|&k| Vec4::from_array(forces[k as usize])).sum::<Vec4>();
            *p = sum.truncate() * scale;
        };
        if parallel {
            push.par_iter_mut().enumerate().for_each(gather);
        } else {
            push.iter_mut().enumerate().for_each(gather);
        }
    }

    pub(super) fn push(&self, solver: &mut dyn Solver) {
        solver.push(&self.push);
    }
}
