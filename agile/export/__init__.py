"""Export of trained policies: TorchScript and ONNX files (`policy_files`), the IO descriptor that goes with them
(`io_descriptor`; the file's format is `agile.rl_env.io_descriptor_file`), and LEAPP bundles (`leapp_bundle`)."""
