"""What every pass of one frame shares, handed by the pipeline to each technique's hooks: the frame, the
target, the frame's uniform block, one object block and (base, shadow) batch per mesh, the shadow atlas of
the emitter being drawn, and the pipeline's resources that outlive the frame (render targets, read-backs)."""
from __future__ import annotations

import dataclasses

from ..core.frame import FrameInputs


@dataclasses.dataclass
class FrameContext:
    frame: FrameInputs
    target: object  # GPUFrameBuffer the frame is drawn into
    frame_ubo: object  # GPUUniformBuf: camera, world (blocks.frame_block)
    objects: list  # GPUUniformBuf per mesh (blocks.object_block)
    batches: list  # (base batch, shadow batch) per mesh
    shadow_atlas: object  # GPUTexture: the shadow distances of the emitter being drawn
    resources: object  # the Pipeline: ``targets`` (render targets by name) and ``capture`` (read-backs or None)

    @property
    def size(self) -> tuple[int, int]:
        return self.frame.camera.width, self.frame.camera.height
