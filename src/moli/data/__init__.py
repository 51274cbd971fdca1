"""Records in: the IOData container, file readers and writers, DaISy data sets, test signals."""

from .chunks import RecordChunk, list_chunks
from .daisy import (
    DaisyInfo, DatasetChecksumError, DatasetUnavailableError, daisy_path, daisy_url, list_daisy,
    load_daisy,
)
from .files import fingerprint, from_dataframe, read_data, to_dataframe
from .iodata import IOData
from .signals import SignalError, random_binary_signal

__all__ = [
    "IOData", "read_data", "from_dataframe", "to_dataframe", "fingerprint",
    "DaisyInfo", "DatasetChecksumError", "DatasetUnavailableError", "daisy_path", "daisy_url",
    "list_daisy", "load_daisy", "SignalError", "random_binary_signal",
    "RecordChunk", "list_chunks",
]
