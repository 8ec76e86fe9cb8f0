"""The GPU layer under the techniques: shader builder (one GLSL source per pass, through GPUShaderCreateInfo),
render targets, uniform-block layouts, the bake GPU's moderngl contexts and the cache of baked GPU resources.
"""
