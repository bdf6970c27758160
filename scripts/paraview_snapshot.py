"""Screenshots of a run's fields.xdmf as ParaView shows it (the last and the middle output):
the 2D box's outline and its material cells (flag 1 Fluid or 2 Surface) coloured by the downslope
velocity u, and under the bed the depth-averaged strip coloured by its u. Not a CI dependency.

  xvfb-run -a pvbatch scripts/paraview_snapshot.py OUTPUT_DIR/fields.xdmf PREFIX

writes PREFIX_last.png and PREFIX_mid.png. For a coupled run the 'ndam' block is the channel-wide
2D grid (flag -1 and zero fields in the columns that are 1D at that output) and the 'dam' block
the depth-averaged strip under the bed, so the series stays one series while interfaces move;
fields.xdmf holds one temporal collection per block, so the blocks keep their names at every
time (an Extract Block of /Root/ndam works at every output).
"""
import sys

from paraview.simple import (GetActiveViewOrCreate, GetAnimationScene, GetColorTransferFunction,
                             ColorBy, ExtractBlock, Render, SaveScreenshot, Show, Threshold,
                             XDMFReader)

path, out = sys.argv[1], sys.argv[2]
r = XDMFReader(FileNames=[path])
r.UpdatePipelineInformation()
times = r.TimestepValues
scene = GetAnimationScene()
scene.UpdateAnimationUsingDataTimeSteps()
v = GetActiveViewOrCreate('RenderView')
v.ViewSize = [1600, 400]
v.CameraParallelProjection = 1
box = Show(r, v)
box.SetRepresentationType('Outline')
material = Threshold(Input=r, Scalars=['CELLS', 'flag'], LowerThreshold=1, UpperThreshold=2)
d = Show(material, v)
ColorBy(d, ('CELLS', 'u'))
d.SetScalarBarVisibility(v, True)
# the depth-averaged model's strip under the bed (a coupled run's 1D flow: u_mean, and 0 where
# the 2D model runs); its block keeps the name 'dam' at every output
strip = ExtractBlock(Input=r, Selectors=['/Root/dam'])
ds = Show(strip, v)
ColorBy(ds, ('CELLS', 'u'))
GetColorTransferFunction('u').RescaleTransferFunction(0.0, 3.0)
Render(v)  # paraview.simple resets the camera at a view's first render: before ours is set
for name, t in (('last', times[-1]), ('mid', times[len(times) // 2])):
    scene.AnimationTime = t
    # the whole box in the view: looking at its centre along -z, parallel projection with half
    # the view's height in metres
    b = r.GetDataInformation().GetBounds()
    cx, cy = 0.5 * (b[0] + b[1]), 0.5 * (b[2] + b[3])
    v.CameraPosition = [cx, cy, 10.0]
    v.CameraFocalPoint = [cx, cy, 0.0]
    v.CameraViewUp = [0.0, 1.0, 0.0]
    aspect = v.ViewSize[0] / v.ViewSize[1]
    v.CameraParallelScale = 1.05 * max(0.5 * (b[3] - b[2]), 0.5 * (b[1] - b[0]) / aspect)
    Render(v)
    SaveScreenshot(out + '_' + name + '.png', v, ImageResolution=v.ViewSize)
print('wrote', out + '_last.png', out + '_mid.png', 'of', len(times), 'outputs')
