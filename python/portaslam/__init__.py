"""PortaSLAM for Python: the feature frontend on any compute backend, the stereo SLAM system,
the dataset readers and the trajectory evaluation (docs/PYTHON.md).

    import portaslam
    frontend = portaslam.Frontend(1242, 375, backend="cpu")
    pair = frontend.detect_stereo(left, right)      # (H, W) uint8 numpy arrays
    pair.left.keypoints, pair.left.descriptors, pair.matches

Images are 2-D uint8 arrays (gray). Calls into the engine release the GIL.
"""
from ._portaslam import (  # noqa: F401
    KEYPOINT_DTYPE,
    MATCH_DTYPE,
    BackendError,
    Dataset,
    DatasetError,
    EvaluationError,
    Features,
    Frontend,
    FrontendSettings,
    MapFileError,
    SettingsError,
    SettingsFileError,
    SlamSettings,
    StereoCamera,
    StereoFeatures,
    System,
    Trajectory,
    TrajectoryError,
    __version__,
    backends,
    evaluate,
    open_dataset,
)
