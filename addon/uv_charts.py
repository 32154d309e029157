"""The UV map lightmaps are laid out in: `RadiosityUV`, used as it is when the mesh has one, else
made with Blender's Lightmap Pack. The mesh's active and render UV maps stay what they were."""
UV_MAP = "RadiosityUV"

# Lightmap Pack's margin round each chart, in texels of the image the map is made for (charts lie
# twice that apart): room for padding, so that bilinear filtering and the first mip levels beside
# one chart read no other chart's light.
MARGIN_TEXELS = 4


def ensure_uv_map(me, image_size):
    """me's RadiosityUV layer, made if missing for an image of `image_size` texels a side.
    None if the mesh has no room for another UV map (Blender allows 8)."""
    layer = me.uv_layers.get(UV_MAP)
    if layer is not None:
        return layer
    active = me.uv_layers.active.name if me.uv_layers.active is not None else None
    render = next((l.name for l in me.uv_layers if l.active_render), None)
    layer = me.uv_layers.new(name=UV_MAP, do_init=False)
    if layer is None:
        return None
    # Lightmap Pack's own function: the operator would need the object active and selected in a
    # view layer, and it writes into the active map, which is therefore RadiosityUV for the call.
    from bl_operators.uvcalc_lightmap import lightmap_uvpack
    me.uv_layers.active = layer
    try:
        lightmap_uvpack([me], PREF_SEL_ONLY=False, PREF_NEW_UVLAYER=False, PREF_PACK_IN_ONE=False,
                        PREF_APPLY_IMAGE=False, PREF_BOX_DIV=12,
                        PREF_MARGIN_DIV=max(1, image_size // MARGIN_TEXELS))
    finally:
        if active is not None:
            me.uv_layers.active = me.uv_layers[active]
        if render is not None:
            me.uv_layers[render].active_render = True
    return me.uv_layers[UV_MAP]
