"""Everything that touches bpy: the render engine, the viewport draw handler, reading the scene (extract, bake
inputs), properties, panels, preferences, the demo scenes and the Cycles comparison runner.
"""
