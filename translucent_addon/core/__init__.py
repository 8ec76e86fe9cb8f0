"""Pure code under everything: physics, geometry, the frame description, lights, references, metrics, the report
and its charts, bake storage. Never imports bpy or gpu.
"""
