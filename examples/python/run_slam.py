"""Stereo SLAM on a KITTI-layout folder (e.g. one `portaslam render` wrote) from Python: the
trajectory to trajectory_tum.txt and, when the folder has ground truth, the ATE.

    python3 examples/python/run_slam.py SEQUENCE [--backend NAME]
"""
import argparse
import sys

import portaslam


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sequence")
    parser.add_argument("--backend", default="cpu")
    args = parser.parse_args()
    try:
        dataset = portaslam.open_dataset("kitti", args.sequence)
        system = portaslam.System(portaslam.SlamSettings(dataset.camera), backend=args.backend)
        for i in range(len(dataset)):
            left, right, time_s = dataset[i]
            system.process(left, right, time_s)
        system.finish()
    except (portaslam.DatasetError, portaslam.BackendError) as error:
        sys.exit(f"run_slam.py: {error}")

    trajectory = system.trajectory()
    trajectory.write("trajectory_tum.txt", "tum")
    print(f"{len(trajectory)} of {len(dataset)} frames tracked, {system.num_keyframes} keyframes")
    if dataset.ground_truth is not None:
        metrics = portaslam.evaluate(dataset.ground_truth, trajectory)
        print(f"ATE RMSE {metrics['ate_m']['rmse']:.4f} m over {metrics['pairs']} poses")


if __name__ == "__main__":
    main()
