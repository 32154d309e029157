"""Cycles settings for an unbiased reference (DESIGN.md section 4): no denoising, no adaptive
sampling, no clamping, and diffuse bounces only (the scenes are diffuse). Cycles counts a path
passing through a lamp as a transparent bounce and ends it past the transparent limit: at 0 an area
lamp absorbed every path that hit it, 0.8% of the light per bounce in a closed room with a 1 x 0.6 m
lamp (3.6% in all at rho 0.8). Blender's default lets a path through 8."""


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
    cy.transparent_max_bounces = diffuse_bounces
    cy.seed = seed


def with_optics(scene, bounces=64):
    """unbiased() for scenes whose light passes through panes or off mirrors (the optics samples):
    glossy and transmission bounces raised, caustics allowed and glossy not blurred, so that light
    carried by a mirror or a pane to a diffuse surface is all there."""
    cy = scene.cycles
    cy.glossy_bounces = bounces
    cy.transmission_bounces = bounces
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    cy.blur_glossy = 0.0
