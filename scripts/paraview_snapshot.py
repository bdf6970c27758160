"""Screenshots of a run's fields.xdmf as ParaView shows it (the last and the middle output),
coloured by the downslope velocity u. Not a CI dependency.

  xvfb-run -a pvbatch scripts/paraview_snapshot.py OUTPUT_DIR/fields.xdmf PREFIX

writes PREFIX_last.png and PREFIX_mid.png. For a coupled run the 'ndam' block is the channel-wide
2D grid (flag -1 and zero fields in the columns that are 1D at that output) and the 'dam' block
the depth-averaged strip under the bed, so the series stays one series while interfaces move.
"""
import sys

from paraview.simple import (GetActiveViewOrCreate, GetAnimationScene, GetColorTransferFunction,
                             ColorBy, Render, SaveScreenshot, Show, XDMFReader)

path, out = sys.argv[1], sys.argv[2]
r = XDMFReader(FileNames=[path])
r.UpdatePipelineInformation()
times = r.TimestepValues
scene = GetAnimationScene()
scene.UpdateAnimationUsingDataTimeSteps()
v = GetActiveViewOrCreate('RenderView')
v.ViewSize = [1600, 360]
v.CameraParallelProjection = 1
d = Show(r, v)
ColorBy(d, ('CELLS', 'u'))
d.SetScalarBarVisibility(v, True)
GetColorTransferFunction('u').RescaleTransferFunction(0.0, 3.0)
for name, t in (('last', times[-1]), ('mid', times[len(times) // 2])):
    scene.AnimationTime = t
    v.ResetCamera()
    v.CameraParallelScale = 0.12
    Render(v)
    SaveScreenshot(out + '_' + name + '.png', v)
print('wrote', out + '_last.png', out + '_mid.png', 'of', len(times), 'outputs')
