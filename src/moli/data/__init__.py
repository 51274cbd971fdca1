"""Records in: the IOData container, file readers and writers, DaISy data sets, test signals, frequency responses."""

from .chunks import RecordChunk, list_chunks
from .daisy import (
    DaisyInfo, DatasetChecksumError, DatasetUnavailableError, daisy_path, daisy_url, list_daisy,
    load_daisy,
)
from .frequency_data import FrequencyData
from .frequency_files import read_frequency_data
from .periodic import frequency_response
from .files import file_sha256, fingerprint, read_data, to_dataframe
from .iodata import IOData, merge
from .outliers import OutlierReport, flag_outliers, remove_outliers
from .quality import QualityIssue, check_data, screen
from .signals import SignalError, random_binary_signal
from .tables import from_columns, from_dataframe
from .text_files import detect_encoding
from .timing import SamplingGap, find_gaps

__all__ = [
    "IOData", "merge", "read_data", "from_columns", "from_dataframe", "to_dataframe", "fingerprint",
    "file_sha256", "detect_encoding", "SamplingGap", "find_gaps",
    "DaisyInfo", "DatasetChecksumError", "DatasetUnavailableError", "daisy_path", "daisy_url",
    "list_daisy", "load_daisy", "SignalError", "random_binary_signal", "QualityIssue", "check_data",
    "screen", "OutlierReport", "flag_outliers", "remove_outliers", "RecordChunk", "list_chunks",
    "FrequencyData", "read_frequency_data", "frequency_response",
]
