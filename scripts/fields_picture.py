"""A picture of a fields grid in ParaView (pvbatch under xvfb): the mid-plane y slice of
fields.xdmf coloured by one field.

    talus run cases/chute.toml --out out/chute --set output.snapshot_interval=0.01 --set output.contacts=true
    talus fields out/chute --width 0.0015 --grid 32,16,40 --from 0.3
    xvfb-run -a pvbatch scripts/fields_picture.py out/chute velocity docs/img/chute-velocity.png
    xvfb-run -a pvbatch scripts/fields_picture.py out/chute stress_zz docs/img/chute-stress-zz.png

(ParaView and xvfb from Debian: apt-get install paraview xvfb.)
"""
import sys

from paraview.simple import (ColorBy, CreateView, GetColorTransferFunction, GetScalarBar, Render, SaveScreenshot, Show,
                             Slice, XDMFReader)

run, field, png = sys.argv[1], sys.argv[2], sys.argv[3]
grid = XDMFReader(FileNames=[f"{run}/fields.xdmf"])
grid.UpdatePipeline()
b = grid.GetDataInformation().GetBounds()
centre = [(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2]
view = CreateView("RenderView")
view.ViewSize = [900, 700]
view.Background = [1, 1, 1]
view.OrientationAxesVisibility = 0
sl = Slice(Input=grid)
sl.SliceType = "Plane"
sl.SliceType.Origin = centre
sl.SliceType.Normal = [0, 1, 0]
d = Show(sl, view)
ColorBy(d, ("POINTS", field, "Magnitude") if field == "velocity" else ("POINTS", field))
d.SetScalarBarVisibility(view, True)
lut = GetColorTransferFunction(field)
lut.ApplyPreset("Viridis (matplotlib)", True)
bar = GetScalarBar(lut, view)
bar.Title = {"velocity": "velocity (m/s)", "density": "density (kg/m^3)"}.get(field, f"{field} (Pa)")
bar.TitleColor = bar.LabelColor = [0, 0, 0]
view.CameraPosition = [centre[0], centre[1] - 10 * (b[5] - b[4]), centre[2]]
view.CameraFocalPoint = centre
view.CameraViewUp = [0, 0, 1]
view.ResetCamera()
Render(view)
SaveScreenshot(png, view, ImageResolution=[900, 700])
print(f"wrote {png}")
