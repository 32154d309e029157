"""Cycles settings for an unbiased reference (DESIGN.md section 4): no denoising, no adaptive
sampling, no clamping, and diffuse bounces only (the scenes are diffuse)."""


def unbiased(scene, samples, diffuse_bounces, seed):
    scene.render.engine = 'CYCLES'
    cy = scene.cycles
    cy.device = 'CPU'
    cy.samples = samples
    cy.use_denoising = False
    cy.use_adaptive_sampling = False
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.diffuse_bounces = diffuse_bounces
    cy.max_bounces = diffuse_bounces
    cy.glossy_bounces = 0
    cy.transmission_bounces = 0
    cy.transparent_max_bounces = 0
    cy.seed = seed
