/* QUADGRAPH block layout (Wang 2010 Sec. 5.1): slot s of a level lives in block s / r^2, blocks
 * laid out blocks_per_row across, r x r texels each (bake/quadgraph.py TextureLayout). */
#define QG_BLOCK 32

ivec2 qg_texel(int slot, int blocks_per_row)
{
  int b = slot / (QG_BLOCK * QG_BLOCK);
  int l = slot - b * QG_BLOCK * QG_BLOCK;
  return ivec2((b % blocks_per_row) * QG_BLOCK + l % QG_BLOCK, (b / blocks_per_row) * QG_BLOCK + l / QG_BLOCK);
}

int qg_slot(ivec2 texel, int blocks_per_row)
{
  ivec2 b = texel / QG_BLOCK;
  ivec2 l = texel - b * QG_BLOCK;
  return (b.y * blocks_per_row + b.x) * QG_BLOCK * QG_BLOCK + l.y * QG_BLOCK + l.x;
}
